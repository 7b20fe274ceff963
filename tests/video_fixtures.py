"""Small videos for the tests, written with PyAV: MJPEG (each frame its own picture, so a
damaged one is lost alone) or any codec and pixel format asked for."""

import numpy as np


def write_frames(path, images, codec="mjpeg", pix_fmt="yuvj420p", rate=25):
    """A video of gray uint8 images (H, W), all of one size; returns ``path``."""
    import av

    container = av.open(str(path), "w")
    stream = container.add_stream(codec, rate=rate)
    stream.height, stream.width = images[0].shape
    stream.pix_fmt = pix_fmt
    for image in images:
        frame = av.VideoFrame.from_ndarray(np.repeat(image[..., None], 3, axis=2),
                                           format="rgb24")
        for packet in stream.encode(frame):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)
    container.close()
    return path


def damage_jpeg_frame(path, index):
    """Blank frame ``index``'s JPEG data in an MJPEG file, so that it can't be decoded."""
    data = bytearray(path.read_bytes())
    starts = [i for i in range(len(data) - 1) if data[i] == 0xFF and data[i + 1] == 0xD8]
    end = starts[index + 1] - 16  # the next frame's chunk header stays
    data[starts[index]:end] = bytes(end - starts[index])
    path.write_bytes(bytes(data))
