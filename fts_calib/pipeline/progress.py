"""Where a calibration session stands: counts, rank and what is still missing."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Progress:
    """Where a session stands.

    Attributes:
        seen: Samples offered.
        kept: Samples that entered the least squares.
        kept_by_configuration: Kept samples per tool configuration name.
        rank: Rank of S_XX of the offset model in use (``full_rank`` determines every coefficient).
        condition_number: Of the scaled S_XX (inf below full rank).
        missing: What is still missing, in words ('' at full rank).
        skipped: Samples not kept, by reason (checks and filter rules).
        last_time: Time of the last sample [s], or None.
        full_rank: 6 + the offset model's columns (7 for constant offsets).
    """

    seen: int
    kept: int
    kept_by_configuration: dict[str, int]
    rank: int
    condition_number: float
    missing: str
    skipped: dict[str, int]
    last_time: float | None
    full_rank: int = 7

    @property
    def kept_fraction(self) -> float:
        """Kept samples over seen samples (0 when none seen)."""
        return self.kept / self.seen if self.seen else 0.0
