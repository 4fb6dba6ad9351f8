"""Reading dirty tracked curves (UsdGeomBasisCurves, NurbsCurves, HermiteCurves) into the
delegate's curves rprims, prim by prim: their data (:func:`~.curves.sync_curves_data`), and,
as for points (:class:`~.points_sync.PointsSync`, whose placement it shares), transforms and
positions over the shutter, visibility (and render-pass visibility) and material binding."""

from __future__ import annotations

from pxr import Sdf, Usd

from .curves import sync_curves_data
from .points_sync import PointsSync
from .prim_sync import SyncSettings
from .sampling import SampleReader


class CurvesSync(PointsSync):
    """Curves, sampled over the shutter."""

    def _read(
        self, path: Sdf.Path, path_str: str, prim: Usd.Prim, reader: SampleReader,
        settings: SyncSettings,
    ) -> bool:
        return sync_curves_data(self.core, prim, reader, self._warn, path_str, self._skel_caches)
