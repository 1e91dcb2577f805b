"""Aims of study: what a station is after, named the way AEGIS's target profiles are (2.5).

An aim is one *kind* of target sought first, optionally with *exclusions* (kinds ranked
after everything else), written ``KIND[+EXCLUSION...]``: ``dark``, ``bright+no-sky``,
``no-vegetation`` (= ``any+no-vegetation``). It reorders what the science found; it never
hides a striking target of another kind (that one is still reported, ranked after).
One place for the names: the bus, ``--aim``, ``[survey] aim``, the keypad and the console.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

__all__ = ["ANY", "EXCLUSIONS", "KINDS", "Aim", "add_aim_argument", "parse_aim"]

KINDS: dict[str, str] = {
    "any": "whatever is most uncommon (no preference)",
    "dark": "dark features: wet stains, dark lenses, desert varnish",
    "bright": "bright features: veins, evaporites, pale clasts",
    "colour": "strongly coloured features: lichen, oxides",
}
"""The kinds an aim may seek, with what each means to a field scientist."""

EXCLUSIONS: dict[str, str] = {
    "no-vegetation": "plants are not what is sought: ranked after everything else",
    "no-sky": "sky is not what is sought: ranked after everything else",
}
"""Kinds an aim may set aside (they combine with any kind)."""


@dataclass(frozen=True)
class Aim:
    """A parsed aim: the kind sought first and the kinds ranked last."""

    kind: str = "any"
    exclude: frozenset[str] = frozenset()

    @property
    def text(self) -> str:
        """The canonical form: kind first, exclusions in :data:`EXCLUSIONS` order.

        >>> parse_aim("no-sky+dark+no-vegetation").text
        'dark+no-vegetation+no-sky'
        >>> parse_aim("any+no-sky").text, parse_aim("any").text
        ('no-sky', 'any')
        """
        parts = [name for name in EXCLUSIONS if name in self.exclude]
        if self.kind != "any" or not parts:
            parts.insert(0, self.kind)
        return "+".join(parts)

    @property
    def neutral(self) -> bool:
        """True for ``any`` with no exclusion: the ranking is the science's own."""
        return self.kind == "any" and not self.exclude


ANY = Aim()


def parse_aim(text: str) -> Aim:
    """Read ``KIND[+EXCLUSION...]``; a clear ``ValueError`` names what is wrong.

    >>> parse_aim("Dark + no-vegetation")
    Aim(kind='dark', exclude=frozenset({'no-vegetation'}))
    >>> parse_aim("dark+bright")
    Traceback (most recent call last):
    ...
    ValueError: aim 'dark+bright': one kind at most (dark, bright)
    >>> parse_aim("wet")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: aim 'wet': unknown 'wet' (kinds: any, dark, bright, colour; exclusions: ...)
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"aim {text!r}: empty (kinds: {', '.join(KINDS)})")
    kinds: list[str] = []
    exclude: set[str] = set()
    for raw in text.split("+"):
        name = raw.strip().lower().replace("_", "-")
        if name in KINDS:
            kinds.append(name)
        elif name in EXCLUSIONS:
            exclude.add(name)
        else:
            raise ValueError(
                f"aim {text!r}: unknown {name!r} (kinds: {', '.join(KINDS)}; "
                f"exclusions: {', '.join(EXCLUSIONS)})"
            )
    if len(kinds) > 1:
        raise ValueError(f"aim {text!r}: one kind at most ({', '.join(kinds)})")
    return Aim(kinds[0] if kinds else "any", frozenset(exclude))


def _aim(text: str) -> str:
    """argparse's reading of ``--aim``: the canonical form, or a usage error naming the kinds."""
    try:
        return parse_aim(text).text
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_aim_argument(parser: argparse._ActionsContainer, otherwise: str) -> None:
    """``--aim KIND[+EXCLUSION...]`` (into ``aim``, canonical, None when not given), its help
    listing every name; ``otherwise`` says what applies without it. One spelling for every
    command line (``cyborg survey``, ``cyborgd analyze``)."""
    kinds = "; ".join(f"{name}: {what}" for name, what in KINDS.items())
    exclusions = ", ".join(EXCLUSIONS)
    parser.add_argument(
        "--aim",
        type=_aim,
        metavar="KIND[+EXCLUSION]",
        help=f"what is sought first ({kinds}); exclusions, ranked last, combine with a kind "
        f"by + ({exclusions}), e.g. --aim dark+no-vegetation; a striking target of another "
        f"kind is still reported, after; {otherwise}",
    )
