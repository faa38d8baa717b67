"""Brushes whose paint carries detail of a fixed size on the canvas (oil's bristles, watercolor's paper,
the marker's streaks): each part drawn on a canvas wide enough to show it, its mean elsewhere."""
from __future__ import annotations

import dataclasses

from torch import Tensor

from nsp.brushes.base import Brush


@dataclasses.dataclass(frozen=True, eq=False)
class Detailed(Brush):
    """A brush whose paint has parts (:meth:`parts`) drawn by the canvas's width, or fixed by ``detail``."""

    detail: tuple[bool, ...] | None = None  # the parts drawn at every size; None: the canvas's
    _cache: dict = dataclasses.field(default_factory=dict, repr=False)

    def parts(self, width: int | Tensor) -> tuple[bool, ...]:
        """Which parts of its paint this brush draws on a canvas ``width`` px wide (none at 0)."""
        raise NotImplementedError

    def plain(self) -> "Detailed":
        return self._with(self.parts(0))

    def sized(self, width: int) -> "Detailed | None":
        return self._with(self._parts(width))

    def varies(self, width: int) -> bool:
        return any(self._parts(width))

    @property
    def variant(self) -> str:
        return "" if self.detail is None else "detail" + "".join(str(int(part)) for part in self.detail)

    def _with(self, detail: tuple[bool, ...]) -> "Detailed":
        """This brush drawing the parts ``detail`` on a canvas of any size."""
        if detail not in self._cache:
            self._cache[detail] = dataclasses.replace(self, detail=detail, _cache={})
        return self._cache[detail]

    def _parts(self, width: int | Tensor) -> tuple[bool, ...]:
        """The parts this brush draws on a canvas ``width`` px wide: ``detail``, else :meth:`parts`."""
        return self.parts(width) if self.detail is None else self.detail
