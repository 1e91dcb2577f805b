"""The aims bench's mixed views (``bench.aims``): a target counts as its kind only when the
rendered image shows it as that kind, and the all-scenes figure stays what it was."""

import dataclasses

import numpy as np

from bench.aims import BASES, JND, contrasts, mixed_scene, summarise, visible


def _vein_painted(scene, offset: float):
    """``scene`` with its vein's pixels shifted so that its median is ``offset`` grey levels
    off its host rock's (grey rock: no clipping)."""
    k = next(i for i, t in enumerate(scene.targets) if t.kind == "vein")
    vein = scene.target_labels == k + 1
    image = scene.image.astype(np.float32)
    image[vein] += offset - contrasts(scene)["vein"][0]
    return dataclasses.replace(scene, image=np.clip(image, 0, 255).astype(np.uint8))


def test_a_vein_is_bright_only_when_the_rendered_image_shows_it_brighter_than_its_host():
    scene = mixed_scene(3, "grey")
    assert visible("dark", contrasts(scene)["wet_stain"]) == ""
    assert visible("colour", contrasts(scene)["lichen"]) == ""
    assert visible("bright", contrasts(_vein_painted(scene, 4 * JND))["vein"]) == ""
    assert visible("bright", contrasts(_vein_painted(scene, -4 * JND))["vein"]) == (
        "darker than its host"
    )


def test_the_visible_figure_leaves_the_all_scenes_figure_and_counts_what_it_sets_aside():
    base = BASES[0]
    firsts = {"1": ["vein"], "2": ["plant"], "3": ["vein"], "4": ["plant"]}
    result = {"any": {b: {} for b in BASES}, "bright": {b: {} for b in BASES}}
    result["any"][base] = {k: ["plant"] for k in firsts}
    result["bright"][base] = firsts
    lit, faint, dark = (2 * JND, 0.0), (JND / 2, 0.0), (-2 * JND, 0.0)
    seen = {b: {} for b in BASES}
    seen[base] = {k: {"vein": c} for k, c in zip(firsts, (lit, faint, lit, dark), strict=True)}
    before, after = summarise(result)["bright"], summarise(result, seen)["bright"]
    assert before["sought1"] == after["sought1"] == 0.5
    assert (after["visible"], after["sought1_visible"]) == (2, 1.0)
    assert after["aside"] == {"brighter than its host by < 10": 1, "darker than its host": 1}
