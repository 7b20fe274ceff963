"""Pictures of maps a person can read: a disparity or depth map in the Turbo colormap,
invalid pixels black (a colour Turbo does not use), and under it a colour bar with its
values, its units and the range as numbers, in type sized to the picture.

Turbo (Google, 2019) is held here as a small table, so no plotting library is needed;
tests/library/test_pictures.py checks it against matplotlib's.  Every preview csw makes
comes from this table: a still's (disparity_picture, and a striped map's band by band
through csw.io.formats.colorize) and a video frame's (DisparityColours, the same colours
to a level, in the few steps a frame can afford).
"""

import numpy as np

INVALID = (0, 0, 0)
TEXT = (235, 235, 235)
BACKGROUND = (72, 72, 72)  # lighter than the invalid black, darker than the text
TICKS = 5  # labelled values on the bar, its ends included

# Turbo at 33 evenly spaced points of 0..1 (Google's table, every 8th entry); linear
# between them, it stays within 3 levels of the full table.
_TURBO_POINTS = np.array([
    [48, 18, 59], [57, 42, 115], [64, 64, 162], [68, 86, 199], [70, 107, 227],
    [70, 128, 246], [66, 148, 255], [55, 168, 250], [40, 188, 235], [28, 205, 216],
    [24, 221, 194], [31, 233, 175], [50, 242, 152], [78, 249, 125], [109, 254, 98],
    [139, 255, 75], [164, 252, 60], [183, 247, 53], [203, 237, 52], [221, 224, 55],
    [236, 209, 58], [247, 193, 58], [253, 174, 53], [254, 153, 44], [251, 129, 34],
    [245, 105, 24], [236, 83, 15], [225, 65, 9], [210, 49, 5], [193, 35, 2], [172, 23, 1],
    [149, 13, 1], [122, 4, 3]], np.float64)
TURBO = np.round(np.stack(
    [np.interp(np.linspace(0, 1, 256), np.linspace(0, 1, len(_TURBO_POINTS)), channel)
     for channel in _TURBO_POINTS.T], axis=1)).astype(np.uint8)  # (256, 3)


def turbo(t):
    """uint8 (..., 3): Turbo at t (float, 0..1; clipped), t=0 dark blue, 1 dark red."""
    index = np.round(np.clip(np.asarray(t, np.float64), 0, 1) * 255).astype(np.intp)
    return TURBO[index]


def colour(values, low, high, reverse=False):
    """uint8 (H, W, 3): float ``values`` (NaN invalid) in Turbo over low..high (clipped),
    invalid black; ``reverse`` puts low at the red end."""
    span = max(high - low, 1e-12)
    # In float64 whatever the map's type, so that a map and its stripes colour alike.
    t = (np.nan_to_num(np.asarray(values, np.float64), nan=low) - low) / span
    picture = turbo(1 - t if reverse else t)
    picture[~np.isfinite(values)] = INVALID
    return picture


def font_size(width):
    """Type a reader can read on a picture ``width`` wide, shown fitted to a screen."""
    return int(np.clip(round(width / 38), 12, 72))


def number(value):
    """A bar's value, short and without an exponent for any depth or disparity."""
    size = abs(value)
    if size >= 100 or value == round(value):
        return f"{value:.0f}"
    return f"{value:.1f}" if size >= 10 else f"{value:.3g}"


def bar(width, low, high, label, reverse=False, note=None):
    """uint8 (h, width, 3): the colour bar of a picture ``width`` wide showing low..high:
    the ramp, TICKS values under it, and a line naming ``label`` (what and its units),
    the range (and ``note`` after it), and the invalid colour."""
    from PIL import Image, ImageDraw, ImageFont

    size = font_size(width)
    font = ImageFont.load_default(size=size)
    margin = max(size // 2, 4)
    ramp_h = max(size, 8)
    height = margin + ramp_h + size // 3 + 2 * (size + margin)
    canvas = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(canvas)
    left, right = margin, max(width - margin, margin + 2)
    t = np.linspace(0, 1, right - left)
    ramp = turbo(1 - t if reverse else t)
    canvas.paste(Image.fromarray(np.repeat(ramp[None], ramp_h, axis=0)), (left, margin))
    y = margin + ramp_h + size // 3
    for k in range(TICKS):
        value = low + (high - low) * k / (TICKS - 1)
        x = left + (right - left - 1) * k / (TICKS - 1)
        text = number(value)
        text_w = draw.textlength(text, font=font)
        anchor_x = min(max(x - text_w / 2, 0), width - text_w)
        draw.line([(x, y - size // 3), (x, y - 1)], fill=TEXT, width=max(size // 12, 1))
        draw.text((anchor_x, y), text, fill=TEXT, font=font)
    y += size + margin // 2
    swatch = size
    draw.rectangle([left, y, left + swatch, y + swatch], fill=INVALID, outline=TEXT)
    caption = f"invalid    {label}: {number(low)} .. {number(high)}" + \
        (f", {note}" if note else "")
    draw.text((left + swatch + margin // 2, y), caption, fill=TEXT, font=font)
    return np.asarray(canvas)


def disparity_picture(disparity, dmin, dmax):
    """uint8 (H + bar, W, 3): a disparity map (float32 (H, W), NaN invalid) in Turbo over
    the range searched, near (large d) red, with its bar."""
    return np.vstack([colour(disparity, dmin, dmax),
                      bar(disparity.shape[1], dmin, dmax, "disparity (pixels)")])


def depth_range(depth):
    """(near, far): the 1st and 99th percentiles of a depth map's valid values (a few
    far outliers would otherwise wash the picture out)."""
    values = depth[np.isfinite(depth)]
    if not values.size:
        return 0.0, 1.0
    near, far = (float(v) for v in np.percentile(values, (1, 99)))
    return near, max(far, near + 1e-6)


def depth_picture(depth, units):
    """uint8 (H + bar, W, 3): a depth map (float32 (H, W), NaN invalid) in Turbo over its
    1st to 99th percentile, near red and far blue, with its bar in ``units``; the bar
    says so where depths lie beyond that range (their colours clipped to its ends)."""
    near, far = depth_range(depth)
    label = f"depth ({units})" if units else "depth (the calibration's units)"
    values = depth[np.isfinite(depth)]
    clipped = bool(values.size) and (values.min() < near or values.max() > far)
    return np.vstack([colour(depth, near, far, reverse=True),
                      bar(depth.shape[1], near, far, label, reverse=True,
                          note="1st-99th percentile, clipped" if clipped else None)])


# A video's frames: the same Turbo table, as packed RGBA (little-endian: R in the first
# byte), with one more entry, black, for invalid pixels: a frame's colours are one lookup
# of 4 bytes a pixel (about 1 ms at 640x480, where indexing the (256, 3) table took 7).
_TURBO_RGBA = np.concatenate([
    TURBO[:, 0].astype(np.uint32) | TURBO[:, 1].astype(np.uint32) << 8
    | TURBO[:, 2].astype(np.uint32) << 16 | np.uint32(255) << 24,
    [np.uint32(INVALID[0] | INVALID[1] << 8 | INVALID[2] << 16 | 255 << 24)]]).astype(np.uint32)


def disparity_colours(disparity, low, high):
    """uint8 (H, W, 4) RGBA, alpha 255: a disparity map (float32 (H, W), NaN invalid) in
    Turbo over low..high, invalid black: csw.io.pictures' colours (to a level), without
    its colour bar, in the few steps a video frame can afford."""
    return DisparityColours()(disparity, low, high)


class DisparityColours:
    """disparity_colours for a stream of maps, its arrays kept for the next map of the same
    size: a call returns the colourer's own array, overwritten by the next call.  Fresh
    arrays each frame paid the first touch of each of their pages: 3.1 ms a 640x480 frame,
    against 1.35 with the arrays kept."""

    def __init__(self):
        self.shape = None

    def __call__(self, disparity, low, high, out=None):
        """The colours of ``disparity``: the colourer's own array, or ``out`` (uint8
        (H, W, 4), C-contiguous: a video frame's rows, coloured in place)."""
        disparity = np.asarray(disparity, np.float32)
        if disparity.shape != self.shape:
            self.shape = disparity.shape
            self.scaled = np.empty(disparity.shape, np.float32)
            self.index = np.empty(disparity.shape, np.uint16)
            self.rgba = np.empty(disparity.shape, np.uint32)
        t, index = self.scaled, self.index
        scale = 255.0 / max(high - low, 1e-12)
        np.subtract(disparity, np.float32(low), out=t)
        t *= np.float32(scale)
        t += np.float32(0.5)
        np.clip(t, 0, 255, out=t)  # NaN stays NaN
        # NaN becomes the last entry, the invalid colour: fmin takes the number where one
        # side is NaN, in one pass (a masked assignment took longer than the rest).
        np.fmin(t, np.float32(len(_TURBO_RGBA) - 1), out=t)
        np.copyto(index, t, casting="unsafe")  # truncation, as astype
        # mode "clip" (the indices are in range already): under the default, "raise",
        # take writes through a buffer the size of the frame (1.0 ms of 640x480, 0.55 so).
        if out is not None:
            np.take(_TURBO_RGBA, index, out=out.view(np.uint32).reshape(disparity.shape),
                    mode="clip")
            return out
        np.take(_TURBO_RGBA, index, out=self.rgba, mode="clip")
        return self.rgba.view(np.uint8).reshape(*disparity.shape, 4)
