"""``with_settings``: every field of ``VisionParams`` can be set from text, and bad text is
refused with a message that names the field."""

from __future__ import annotations

import dataclasses

import pytest

from cyborg.daemon.vision.params import DEFAULT, PAPER, VisionParams, with_settings


def test_every_field_reads_back_its_own_value() -> None:
    """Each field of ``default``, written out as text, reads back to the same value."""

    def text(value: object) -> str:
        if isinstance(value, tuple):
            return ",".join(map(str, value))
        return "none" if value is None else str(value)

    settings = [f"{f.name}={text(getattr(DEFAULT, f.name))}" for f in dataclasses.fields(DEFAULT)]
    assert with_settings(PAPER, settings) == DEFAULT


def test_settings_change_only_what_they_name() -> None:
    p = with_settings(PAPER, ["uncommon=surprisal", " exact_blur = yes ", "min_distance=12"])
    assert (p.uncommon, p.exact_blur, p.min_distance) == ("surprisal", True, 12.0)
    assert p.replace(uncommon="spread", exact_blur=False, min_distance=None) == PAPER
    assert with_settings(DEFAULT, []) == DEFAULT


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("blur", "expected NAME=VALUE"),
        ("=3", "expected NAME=VALUE"),
        ("blurr=3", "did you mean blur"),
        ("blur=wide", "blur: cannot read 'wide' as float"),
        ("max_classes=7.5", "max_classes: cannot read '7.5' as int"),
        ("uncommon=rarest", "rank | spread | surprisal"),
        ("hue_rotate=maybe", "hue_rotate: cannot read 'maybe' as bool"),
        ("min_distance=far", "float or none"),
        ("plane_weights=1,2", "three non-negative weights"),
        ("wide_scale=0.5", "wide_scale must be 0 or above 1"),
    ],
)
def test_bad_settings_are_refused_by_name(setting: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        with_settings(PAPER, [setting])


def test_the_result_is_a_validated_vision_params() -> None:
    assert isinstance(with_settings(PAPER, ["texture_scales=1,3"]), VisionParams)
    with pytest.raises(ValueError, match="texture_surround"):
        with_settings(DEFAULT, ["texture_scales=1,40"])
