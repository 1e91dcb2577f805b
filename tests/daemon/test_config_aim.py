"""``[survey] aim``: read from a real config file, kept canonical, a typo refused by name."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.daemon.config import ConfigError, load


def _survey(tmp_path: Path, lines: str) -> Path:
    path = tmp_path / "cyborgd.toml"
    path.write_text(f"[survey]\n{lines}\n")
    return path


def test_the_configured_aim_is_kept_in_its_canonical_form(tmp_path: Path) -> None:
    assert load().survey.aim == "any"
    assert load(_survey(tmp_path, 'aim = "No-Vegetation + dark"')).survey.aim == (
        "dark+no-vegetation"
    )


@pytest.mark.parametrize(
    ("lines", "says"),
    [
        ('aim = "wet"', "survey.aim: aim 'wet': unknown 'wet' (kinds: any, dark, bright, colour"),
        ("aim = 3", "survey.aim: expected text"),
        ('settings = ["aim=dark"]', "survey.settings: the aim is the station's own (--aim, "),
    ],
)
def test_a_bad_aim_is_refused_naming_the_key(tmp_path: Path, lines: str, says: str) -> None:
    with pytest.raises(ConfigError) as error:
        load(_survey(tmp_path, lines))
    assert str(error.value).startswith(says), error.value
