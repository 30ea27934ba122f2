"""The segmentation's whole-array steps against plain per-pixel loops."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.segmentation.kernels import (
    cast_shadows,
    frame_boxes,
    lab_differences,
    labelled_components,
    refine_rim,
    seeded_components,
)


def _shadow_reference(soft, bg_soft, inv_norm2, bg_bright, ratio, chroma, noise):
    """The test taken at every pixel, one at a time, in float32."""
    f32 = np.float32
    out = np.zeros(soft.shape[:3], bool)
    for index in np.ndindex(*soft.shape[:3]):
        y, x = index[1:]
        r, g, b = (f32(v) for v in soft[index])
        br, bg, bb = bg_soft[y, x]
        alpha = (r * br + g * bg + b * bb) * inv_norm2[y, x]
        cr, cg, cb = r - alpha * br, g - alpha * bg, b - alpha * bb
        limit = f32(chroma) * alpha * bg_bright[y, x] + f32(noise)
        out[index] = (
            f32(ratio[0]) <= alpha <= f32(ratio[1]) and cr * cr + cg * cg + cb * cb <= limit**2
        )
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cast_shadows_equal_the_test_at_every_pixel(seed):
    rng = np.random.default_rng(seed)
    h, w = 12, 16
    bg = rng.integers(0, 256, (h, w, 3)).astype(np.float32)
    bg[0, :4] = rng.uniform(0, 0.5, (4, 3))  # near black: every pixel tested there
    norm2 = np.maximum(np.einsum("ijk,ijk->ij", bg, bg), 1.0).astype(np.float32)
    darkening = rng.uniform(0.2, 1.2, (3, h, w, 1))
    soft = np.clip(bg * darkening + rng.normal(0, 4, (3, h, w, 3)), 0, 255).astype(np.uint8)
    args = (bg, (1.0 / norm2).astype(np.float32), np.sqrt(norm2), (0.35, 0.92), 0.1, 3.0)
    expected = _shadow_reference(soft, *args)
    assert expected.any() and not expected.all()
    sep, tile = 2, h + 2  # the frames stacked, empty rows between them
    stack = np.zeros((sep + 3 * tile, w, 3), np.uint8)
    stack[sep:].reshape(3, tile, w, 3)[:, :h] = soft
    found = cast_shadows(stack, *args, sep, tile)
    np.testing.assert_array_equal(found[sep:].reshape(3, tile, w)[:, :h], expected)
    assert not found[:sep].any() and not found[sep:].reshape(3, tile, w)[:, h:].any()


def test_lab_differences_in_cie_units():
    rng = np.random.default_rng(3)
    lab = rng.integers(0, 256, (2, 5, 6, 3), dtype=np.uint8)
    bg = rng.integers(0, 256, (5, 6, 3), dtype=np.uint8)
    diff = np.zeros((2, 5, 6, 3), np.float32)
    raw = np.zeros((2, 5, 6), np.float32)
    lab_differences(lab, bg, diff, raw)
    expected = lab.astype(np.float32) - bg
    expected[..., 0] *= np.float32(100.0 / 255.0)
    np.testing.assert_array_equal(diff, expected)
    np.testing.assert_allclose(raw, np.linalg.norm(expected, axis=-1), rtol=1e-6)


def test_components_boxes_and_seeds():
    mask = np.zeros((10, 12), np.uint8)
    mask[1:3, 1:4] = 1  # 6 pixels
    mask[5:9, 6:8] = 1  # 8 pixels
    mask[8, 11] = 1  # 1 pixel
    count, labels, boxes = labelled_components(mask, 8)
    assert count == 4
    by_area = {int(a): tuple(int(v) for v in box) for a, *box in boxes[1:]}
    assert by_area == {6: (1, 1, 3, 2), 8: (6, 5, 7, 8), 1: (11, 8, 11, 8)}
    np.testing.assert_array_equal(boxes[0], 0)
    strong = np.zeros_like(mask, bool)
    strong[6, 6] = strong[8, 11] = True
    kept = seeded_components(labels, count, strong, 2)
    np.testing.assert_array_equal(kept, (labels == labels[6, 6]).astype(np.uint8))


def test_frame_boxes_union_per_frame():
    tile = 10
    boxes = np.array([[5, 2, 1, 4, 3], [3, 7, 2, 8, 6], [4, 1, 21, 2, 25]], np.int64)
    out = frame_boxes(boxes, tile, 4)
    np.testing.assert_array_equal(
        out, [[8, 2, 1, 8, 6], [0, 0, 0, -1, -1], [4, 1, 21, 2, 25], [0, 0, 0, -1, -1]]
    )


def _rim_reference(mask, inside, core, rgb, bg, sep, tile, min_contrast2):
    out = mask.copy()
    h, w = mask.shape
    for y in range(sep, h):
        for x in range(w):
            if not mask[y, x] or inside[y, x]:
                continue
            window = (slice(max(0, y - 3), y + 4), slice(max(0, x - 3), x + 4))
            picked = core[window] != 0
            if not picked.any():
                continue
            body = rgb[window][picked].astype(np.float64).mean(axis=0)
            b = bg[(y - sep) % tile, x].astype(np.float64)
            d = body - b
            contrast2 = d @ d
            p = rgb[y, x].astype(np.float64) - b
            if contrast2 >= min_contrast2 and p @ d < 0.5 * contrast2:
                out[y, x] = 0
    return out


def test_refine_rim_equals_the_loop():
    rng = np.random.default_rng(4)
    sep, h, w = 2, 14, 16
    tile = h + sep
    rows = sep + 2 * tile
    mask = np.zeros((rows, w), np.uint8)
    mask[sep + 3 : sep + 11, 4:12] = 1
    mask[sep + tile + 2 : sep + tile + 12, 3:13] = 1
    inside = np.zeros_like(mask)
    inside[1:-1, 1:-1] = mask[:-2, 1:-1] & mask[2:, 1:-1] & mask[1:-1, :-2] & mask[1:-1, 2:]
    core = inside.copy()
    bg = rng.integers(0, 256, (h, w, 3)).astype(np.float32)
    rgb = rng.integers(0, 256, (rows, w, 3), dtype=np.uint8)
    expected = _rim_reference(mask, inside, core, rgb, bg, sep, tile, 100.0)
    assert (expected != mask).any()
    np.testing.assert_array_equal(
        refine_rim(mask, inside, core, rgb, bg, sep, tile, 100.0), expected
    )
