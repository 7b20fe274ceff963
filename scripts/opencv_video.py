"""The yardstick for ``csw match`` on video: what a user would write with OpenCV alone.
Reads a side-by-side video, matches each frame with StereoBM, and writes the colour
disparity video.  Usage: python opencv_video.py IN.mp4 OUT.mp4 NUM_DISPARITIES"""

import sys

import cv2


def main(source, target, disparities):
    capture = cv2.VideoCapture(source)
    rate = capture.get(cv2.CAP_PROP_FPS) or 30.0
    matcher = cv2.StereoBM_create(numDisparities=disparities, blockSize=9)
    writer = None
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        half = gray.shape[1] // 2
        disparity = matcher.compute(gray[:, :half], gray[:, half:])  # 16 x d, int16
        scaled = cv2.convertScaleAbs(disparity, alpha=255.0 / (16 * disparities))
        colour = cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO)
        if writer is None:
            writer = cv2.VideoWriter(target, cv2.VideoWriter_fourcc(*"mp4v"), rate,
                                     (colour.shape[1], colour.shape[0]))
        writer.write(colour)
    if writer is not None:
        writer.release()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]))
