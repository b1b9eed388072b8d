"""Headless Chromium renders the viewer page with the published scene (non-blank WebGL canvas).

Saves the frame to out/viewer/viewer.png. Skipped when chromium is not installed.
"""

import io
import os
from pathlib import Path

import numpy as np
import pytest

from viewer_fixtures import RECIPE, outputs

CHROMIUM = "/usr/bin/chromium"
OUT = Path(__file__).resolve().parents[2] / "out" / "viewer" / "viewer.png"


def coloured_fraction(png: bytes) -> float:
    """Fraction of saturated pixels (max - min channel > 60) in the 3D area: left of the GUI
    sidebar and below the top-left notification. Greys (grid, background, panel) do not count;
    the zone-coloured toolpath and the section fills do."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    h, w, _ = img.shape
    area = img[int(0.25 * h) :, : int(0.6 * w)]
    sat = area.max(axis=2) - area.min(axis=2)
    return float((sat > 60).mean())


@pytest.mark.skipif(not os.access(CHROMIUM, os.X_OK), reason="chromium not installed")
def test_headless_chromium_shows_the_scene(viewer):
    from waamflow.viewer.screenshot import capture

    viewer.publish("viewer-test", RECIPE, outputs(8))
    png = capture(viewer.url, OUT, width=800, height=500, timeout_s=90, ready=lambda p: coloured_fraction(p) > 0.002)
    frac = coloured_fraction(png)
    print(f"coloured pixel fraction of the 3D area: {frac:.4f} ({OUT})")
    assert OUT.stat().st_size > 5_000, "empty screenshot"
    assert frac > 0.002, f"blank 3D view: only {frac:.4%} coloured pixels in {OUT}"
