"""Episodes of a day of a chain of days: each episode says its day, each goal its history since the day before."""

from __future__ import annotations

from ..records import DayChange, Episode


def label_day(episodes: list[Episode], change: DayChange) -> list[Episode]:
    """Set each episode's `day` and each goal's `history` (unmoved / moved / new, `DayChange.history`); return them."""
    for ep in episodes:
        ep.day = change.day
        for g in ep.goals:
            g.history = change.history(g.object_id)
    return episodes


__all__ = ["label_day"]
