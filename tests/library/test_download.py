"""The download path, against a local HTTP server on 127.0.0.1 serving dataset copies."""

import functools
import http.server
import shutil
import threading
import zipfile

import numpy as np
import pytest

from csw.data import datasets as D


@pytest.fixture
def mirror(tmp_path, data_dir, monkeypatch):
    """Serve copies of tsukuba and wood1 (as the official zip) laid out like the official
    site; point csw at it and at an empty cache."""
    root = tmp_path / "site"
    for relpath in D.DATASETS["tsukuba"].files:
        url = D.FILES[relpath][0]
        dest = root / url[len(D.OFFICIAL_PREFIX):]
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(data_dir / relpath, dest)
    wood = D.DATASETS["wood1"]
    url = D.FILES[wood.left][0]
    archive = root / url[len(D.OFFICIAL_PREFIX):]
    archive.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(archive, "w") as zf:
        for relpath in wood.files:
            zf.write(data_dir / relpath, D.FILES[relpath][2])
    handler = functools.partial(QuietHandler, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    monkeypatch.setenv("CSW_DATA_MIRROR", f"http://127.0.0.1:{server.server_address[1]}/")
    monkeypatch.setenv("CSW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("CSW_DATA_DIR", raising=False)
    for var in ("HTTP_PROXY", "http_proxy", "ALL_PROXY", "all_proxy"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("NO_PROXY", "127.0.0.1")
    yield root
    server.shutdown()
    server.server_close()


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def cache_files(tmp_path):
    cache = tmp_path / "cache"
    return sorted(p.relative_to(cache).as_posix() for p in cache.rglob("*") if p.is_file())


@pytest.mark.slow
@pytest.mark.data
def test_download_fills_the_cache_and_loads(mirror, tmp_path, data_dir):
    pair = D.load("tsukuba", explicit_dir=None, allow_download=True)
    expected = D.load("tsukuba", data_dir, allow_download=False)
    np.testing.assert_array_equal(pair.left, expected.left)
    np.testing.assert_array_equal(pair.gt, expected.gt)
    assert D.is_local("tsukuba")
    assert "tsukuba/scene1.row3.col3.ppm" in cache_files(tmp_path)


@pytest.mark.data
def test_zip_members_are_extracted_and_verified(mirror, tmp_path, data_dir):
    pair = D.load("wood1", allow_download=True)
    expected = D.load("wood1", data_dir, allow_download=False)
    np.testing.assert_array_equal(pair.right, expected.right)
    for relpath in D.DATASETS["wood1"].files:
        assert D.sha256(tmp_path / "cache" / relpath) == D.FILES[relpath][1]


@pytest.mark.data
def test_wrong_checksum_is_an_error_and_leaves_no_cache_entry(mirror, tmp_path):
    served = mirror / D.FILES["tsukuba/scene1.row3.col3.ppm"][0][len(D.OFFICIAL_PREFIX):]
    served.write_bytes(served.read_bytes()[:-10] + b"corrupted!")
    with pytest.raises(D.DataError, match="checksum"):
        D.download("tsukuba/scene1.row3.col3.ppm")
    assert not any(name.startswith("tsukuba/") for name in cache_files(tmp_path))


@pytest.mark.data
def test_corrupt_zip_member_is_an_error_and_leaves_nothing(mirror, tmp_path):
    wood = D.DATASETS["wood1"]
    archive = mirror / D.FILES[wood.left][0][len(D.OFFICIAL_PREFIX):]
    with zipfile.ZipFile(archive, "w") as zf:
        zf.writestr(D.FILES[wood.left][2], b"not the real view1")
    with pytest.raises(D.DataError, match="wrong sha256"):
        D.download(wood.left)
    assert not any(name.startswith("wood1/") for name in cache_files(tmp_path))


def test_unreachable_server_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("CSW_DATA_MIRROR", "http://127.0.0.1:9/")  # discard port: refused
    monkeypatch.setenv("CSW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("NO_PROXY", "127.0.0.1")
    with pytest.raises(D.DataError, match="can't download") as error:
        D.download("tsukuba/truedisp.row3.col3.pgm")
    assert not (tmp_path / "cache" / "tsukuba").exists()  # no empty folder either
    # requests' chain of causes is hundreds of characters: the line gives the gist
    assert "the connection was refused" in str(error.value) and len(str(error.value)) < 300


@pytest.mark.parametrize("kind", ["file", "uncreatable"])
def test_unusable_cache_folder_is_a_clear_error(tmp_path, monkeypatch, kind):
    if kind == "file":
        (tmp_path / "cache").write_text("not a folder")
        cache = tmp_path / "cache"
    else:
        cache = "/proc/csw-cache"  # no one, root included, can create folders there
    monkeypatch.setenv("CSW_CACHE_DIR", str(cache))
    with pytest.raises(D.DataError, match="CSW_CACHE_DIR"):
        D.download("tsukuba/truedisp.row3.col3.pgm")
