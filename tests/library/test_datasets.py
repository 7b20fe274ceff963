"""The registry reads every dataset's ground truth at the right scale."""

import numpy as np
import pytest

from csw.data import datasets as D
from csw.io import read_image

# Largest ground-truth disparity in pixels, from the stored maxima in SOURCES.md divided
# by the documented scale (tsukuba 224/16, venus 158/8, cones 220/4, third size 215/3...).
EXPECTED_MAX = {"tsukuba": 14.0, "venus": 19.75, "sawtooth": 143 / 8, "cones": 55.0,
                "teddy": 52.75, "wood1": 215 / 3, "baby1": 136 / 3, "baby1-half": 68.5,
                "bowling1": 230 / 3, "bowling1-half": 115.0}


def test_every_registry_file_has_an_official_url_and_a_sha256():
    for name, ds in D.DATASETS.items():
        for f in ds.files:
            url, digest, _ = D.FILES[f]
            assert url.startswith(D.OFFICIAL_PREFIX), (name, f)
            assert len(digest) == 64


@pytest.mark.data
@pytest.mark.parametrize("name", sorted(D.DATASETS))
def test_ground_truth_scale_and_range(name, data_dir):
    pair = D.load(name, data_dir, allow_download=False)
    assert pair.dataset.size == f"{pair.left.shape[1]}x{pair.left.shape[0]}"
    assert np.nanmax(pair.gt) == pytest.approx(EXPECTED_MAX[name], abs=1e-4)
    assert np.nanmax(pair.gt) <= pair.dmax <= np.nanmax(pair.gt) + 1
    # Photometric check: the documented scale puts the right image's matching pixel
    # under each left pixel far better than half or twice the scale does.
    def mismatch(scale):
        y, x = np.nonzero(np.isfinite(pair.gt))
        xr = np.round(x - pair.gt[y, x] * pair.dataset.gt_scale / scale).astype(int)
        ok = (xr >= 0) & (xr < pair.left.shape[1])
        diff = pair.left[y[ok], x[ok]].astype(int) - pair.right[y[ok], xr[ok]].astype(int)
        return np.median(np.abs(diff))

    right = mismatch(pair.dataset.gt_scale)
    assert right < 0.5 * mismatch(pair.dataset.gt_scale * 2)
    assert right < 0.5 * mismatch(pair.dataset.gt_scale / 2)


@pytest.mark.data
def test_tsukuba_border_and_palette_masks(data_dir):
    pair = D.load("tsukuba", data_dir, allow_download=False)
    known = np.isfinite(pair.gt)
    assert not known[:18].any() and not known[-18:].any()
    assert not known[:, :18].any() and not known[:, -18:].any()
    # nonocc.png is a palette PNG whose indices are 0/1; its values are 0/255.
    raw = read_image(data_dir / "tsukuba" / "nonocc.png")
    assert set(np.unique(raw)) == {0, 255}
    assert set(np.unique(read_image(data_dir / "tsukuba" / "groundtruth.png"))) == {
        0, 80, 96, 112, 128, 160, 176, 224}
    assert pair.masks["nonocc"].sum() < pair.masks["all"].sum()
    assert (pair.masks["nonocc"] <= pair.masks["all"]).all()
    # disc (values 0/128/255): only 255 is the discontinuity region.
    assert 0 < pair.masks["disc"].sum() < pair.masks["nonocc"].sum()


@pytest.mark.data
@pytest.mark.parametrize("name", ["cones", "teddy", "venus"])
def test_palette_masks_of_2001_and_2003_sets(name, data_dir):
    pair = D.load(name, data_dir, allow_download=False)
    for region in ("nonocc", "disc"):
        share = pair.masks[region].mean()
        assert 0.05 < share < 0.95, (region, share)


def test_synthetic_dataset_is_always_there():
    pair = D.load("synthetic")
    assert D.is_local("synthetic")
    assert pair.left.shape == pair.gt.shape == (375, 450)
    assert np.isfinite(pair.gt).all() and 0.5 < pair.masks["nonocc"].mean() < 1


def test_unknown_dataset_and_missing_data_are_clear(tmp_path, monkeypatch):
    monkeypatch.setenv("CSW_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(D.DataError, match="unknown dataset"):
        D.load("middlebury-9000")
    with pytest.raises(D.DataError, match="CSW_DATA_DIR"):
        D.load("tsukuba", tmp_path / "empty", allow_download=False)
