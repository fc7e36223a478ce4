"""What an agent knows: its declared `Knowledge` (detector, pose sensor, prior exploration, oracle parts, FN).

Agents (`sdovon_mj.nav`) declare it as an attribute ``knowledge``; the evaluation grants exactly that and no more
(`sdovon_mj.suite.protocol`: the agent gets observations built within it, `suite.observation`), and every result
table prints it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from .errors import SdovonError

ORACLE_PARTS = ("navmap", "region_map", "relevance", "instance_labels", "view_points")
POSES = ("gps+compass", "absolute")
PRIORS = ("none", "scene")


class KnowledgeError(SdovonError, PermissionError):
    """An agent read something its declared knowledge does not grant."""


# What a declared word (a detector, an FN variant, an agent's name) may hold: it is printed in result tables, so no
# line break, no cell separator, no markup; 64 characters.
WORD = re.compile(r"[A-Za-z0-9_.+()/-][A-Za-z0-9 _.+()/-]{0,63}")


def check_word(value: Any, what: str) -> str:
    """Return `value` when it is a plain word (`WORD`); raise ValueError naming `what` otherwise."""
    if not isinstance(value, str) or not WORD.fullmatch(value):
        raise ValueError(f"{what} {str(value)[:80]!r} is not a plain word (letters, digits, space, _ . + ( ) / -, at "
                         "most 64 characters)")
    return value


@dataclass(frozen=True)
class Knowledge:
    """What an agent uses: its detector, its pose sensor, prior exploration, oracle parts, FN variant."""

    detector: str = "gt"  # gt: the ground-truth category image of the current frame; anything else: its own model
    pose: str = "gps+compass"  # or "absolute": localized in the scene frame
    prior: str = "none"  # "scene": a first visit of each scene (explore_steps, no goal) before its episodes
    oracle: tuple[str, ...] = ()  # generator artefacts it reads (ORACLE_PARTS): an oracle, an upper bound
    fn: str = "-"  # final navigation after a detection: "paper" (Navigate(p_g|eps_nav), STOP), "retry", "lattice", "-"
    explore_steps: int = 0  # the first visit's step budget (prior="scene"), declared and reported
    rgb: bool = True  # it reads the colour image; False: the evaluator renders none for it (a blank one is sent)

    def __post_init__(self) -> None:
        check_word(self.detector, "detector")
        check_word(self.fn, "FN variant")
        if self.pose not in POSES:
            raise ValueError(f"unknown pose sensor {self.pose!r} ({', '.join(POSES)})")
        if self.prior not in PRIORS:
            raise ValueError(f"unknown prior {self.prior!r} ({', '.join(PRIORS)})")
        if not isinstance(self.rgb, bool):
            raise ValueError(f"rgb must be true or false, got {self.rgb!r}")
        if (self.prior == "scene") != (int(self.explore_steps) > 0):
            raise ValueError(f"prior {self.prior!r} with explore_steps={self.explore_steps}: a first visit "
                             "(prior='scene') needs a step budget > 0, and only it")
        bad = sorted(map(str, set(self.oracle) - set(ORACLE_PARTS)))
        if bad:
            raise ValueError(f"unknown oracle parts {bad} ({', '.join(ORACLE_PARTS)})")

    @property
    def is_oracle(self) -> bool:
        """Return whether the agent reads any generator artefact (then it is a labelled upper bound)."""
        return bool(self.oracle)

    def describe(self) -> str:
        """Return a one-line description for result tables."""
        parts = [f"detector {self.detector}", "pose absolute (localized)" if self.pose == "absolute" else "GPS+compass",
                 f"first visit {self.explore_steps} steps" if self.prior == "scene" else "no prior", f"FN {self.fn}"]
        if not self.rgb:
            parts.append("no colour image")
        if self.oracle:
            parts.append("ORACLE: " + ", ".join(self.oracle))
        return "; ".join(parts)


def knowledge_of(agent: Any) -> Knowledge:
    """Return an agent's declared knowledge (an agent that declares none gets the default: no oracle)."""
    k = getattr(agent, "knowledge", None)
    return k if isinstance(k, Knowledge) else Knowledge()


__all__ = ["Knowledge", "KnowledgeError", "ORACLE_PARTS", "WORD", "check_word", "knowledge_of"]
