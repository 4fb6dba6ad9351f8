"""The times a frame is sampled at, and reading attributes while noting whether what was read
can vary with time.

A frame F seen through a camera with ``shutter:open`` o and ``shutter:close`` c covers the time
codes [F+o, F+c] (docs/design.md §3); moving prims are sampled at K uniformly spaced times over it (the
render delegate interprets sample k at normalised shutter time k/(K−1)). The scene delegate
re-reads, at a new frame or shutter, only the aspects of a prim whose inputs might be
time-varying; :class:`SampleReader` collects that fact while a prim is being read.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

from pxr import Gf, Usd, UsdGeom

DEFAULT_MAX_MOTION_SEGMENTS = 16
"""At most this many uniform steps (17 samples) over the shutter of one frame."""

_GRID_TOLERANCE = 1e-6  # in normalised shutter time


@dataclass(frozen=True)
class Shutter:
    """Frame ``frame`` sampled over the time codes [frame+open, frame+close].

    ``open`` = ``close`` (or the Default frame) samples the frame alone; moving prims get at most
    ``max_segments`` + 1 samples.
    """

    frame: Usd.TimeCode
    open: float = 0.0
    close: float = 0.0
    max_segments: int = DEFAULT_MAX_MOTION_SEGMENTS

    @cached_property  # asked per prim; not a field, so not compared
    def blurred(self) -> bool:
        """Whether the interval has a length (motion is sampled)."""
        return not self.frame.IsDefault() and self.close > self.open

    @property
    def interval(self) -> Gf.Interval:
        """The closed interval of time codes the frame covers."""
        frame = self.frame.GetValue()
        return Gf.Interval(frame + self.open, frame + self.close)

    def segments(self, authored: Iterable[float]) -> int:
        """The fewest uniform steps over the interval whose times include every one of
        ``authored`` (time codes) inside it; ``max_segments`` when no grid up to it does."""
        interval = self.interval
        inside = [
            (t - interval.min) / interval.size for t in authored if interval.min < t < interval.max
        ]
        for count in range(1, self.max_segments + 1):
            if all(abs(u * count - round(u * count)) < _GRID_TOLERANCE for u in inside):
                return count
        return self.max_segments

    def times(self, segments: int) -> list[Usd.TimeCode]:
        """``segments`` + 1 uniformly spaced time codes from open to close (the frame alone when
        the shutter is closed)."""
        if not self.blurred:
            return [self.frame]
        start, length = self.interval.min, self.interval.size
        return [Usd.TimeCode(start + length * k / segments) for k in range(segments + 1)]


def schema_fallback(attr: Usd.Attribute) -> Any:
    """The fallback value the schemas of ``attr``'s prim (its type's and its applied API
    schemas') give ``attr``, or ``None``."""
    return attr.GetPrim().GetPrimDefinition().GetAttributeFallbackValue(attr.GetName())


def value_at(attr: Usd.Attribute, time: Usd.TimeCode) -> Any:
    """The value of ``attr`` at ``time``; where a value block (a ``None`` time sample, "no
    opinion") holds, ``Get`` answers ``None``, and this the schema's fallback, as for an
    attribute left unauthored."""
    value = attr.Get(time)
    return schema_fallback(attr) if value is None else value


def changes_within(attr: Usd.Attribute, interval: Gf.Interval) -> bool:
    """Whether the value of ``attr`` is interpolated between different time samples somewhere
    in ``interval`` (values are held before the first and after the last sample)."""
    samples = attr.GetTimeSamples()
    return len(samples) > 1 and interval.min < samples[-1] and interval.max > samples[0]


class SampleReader:
    """Reads attributes at ``time``; ``varying`` becomes true once any attribute read might vary
    (or, through :meth:`depends_on_shutter`, once what was read depends on the frame or shutter).

    ``shutter``: the interval motion is sampled over, by default ``time`` alone.
    ``note_variability`` False: the caller finds out later whether what it read might vary
    (the reads then cost one USD call less each); ``varying`` is then set only by
    :meth:`depends_on_shutter`. ``queries``: attribute queries by attribute name, kept by the
    caller from one time to the next (a query resolves where the values come from once; it
    must be dropped when the stage is edited), filled as attributes are read.
    """

    def __init__(
        self,
        time: Usd.TimeCode,
        shutter: Shutter | None = None,
        note_variability: bool = True,
        queries: dict[str, Usd.AttributeQuery] | None = None,
    ) -> None:
        self.time = time
        self.shutter = shutter or Shutter(time)
        self.note_variability = note_variability
        self.queries = queries
        self.varying = False

    def depends_on_shutter(self) -> None:
        """Note that what was read must be re-read at another frame or shutter."""
        self.varying = True

    def get(self, attr: Usd.Attribute) -> Any:
        """The value of ``attr`` at the reader's time (``None`` if it has none)."""
        if self.queries is None and not self.note_variability:  # a first sync's usual read
            return attr.Get(self.time)
        if self.queries is not None:
            name = attr.GetName()
            query = self.queries.get(name)
            if query is None:
                query = self.queries[name] = Usd.AttributeQuery(attr)
            attr = query  # answers as the attribute does, from its resolved sources
        if self.note_variability and attr.ValueMightBeTimeVarying():
            self.varying = True
        return attr.Get(self.time)

    def get_or_fallback(self, attr: Usd.Attribute) -> Any:
        """:meth:`get`, a value blocked at the reader's time read as the schema's fallback (see
        :func:`value_at`)."""
        value = self.get(attr)
        return schema_fallback(attr) if value is None else value

    def flattened_primvar(self, primvar: UsdGeom.Primvar) -> Any:
        """The de-indexed value of ``primvar`` at the reader's time (``None`` if it has none)."""
        if self.note_variability and primvar.ValueMightBeTimeVarying():
            self.varying = True
        return primvar.ComputeFlattened(self.time)


def transform_might_vary(prim: Usd.Prim) -> bool:
    """Whether the local-to-world transform of ``prim`` might change with time."""
    while prim and not prim.IsPseudoRoot():
        xformable = UsdGeom.Xformable(prim)
        if xformable and xformable.TransformMightBeTimeVarying():
            return True
        if xformable and xformable.GetResetXformStack():
            return False
        prim = prim.GetParent()
    return False


def visibility_might_vary(prim: Usd.Prim) -> bool:
    """Whether the computed visibility of ``prim`` might change with time."""
    while prim and not prim.IsPseudoRoot():
        imageable = UsdGeom.Imageable(prim)
        if imageable and imageable.GetVisibilityAttr().ValueMightBeTimeVarying():
            return True
        prim = prim.GetParent()
    return False


def primvar_over_attribute(
    gprim: UsdGeom.Gprim, reader: SampleReader, token: str, attribute: Usd.Attribute,
    interpolation: str,
) -> tuple[str, Any, str]:
    """``primvars:<token>`` (flattened) where it is authored, else the schema's ``attribute``
    with ``interpolation``, as UsdImaging reads widths and normals: the name to report, the
    values (``None``: neither is authored) and their interpolation."""
    primvar = UsdGeom.PrimvarsAPI(gprim).GetPrimvar(token)
    if primvar and primvar.HasAuthoredValue():
        values = reader.flattened_primvar(primvar)
        return f"primvars:{token}", values, str(primvar.GetInterpolation())
    values = reader.get(attribute) if attribute.HasAuthoredValue() else None
    return token, values, str(interpolation)
