"""The light a stage without lights is rendered under (never a prim of the stage).

``"camera"`` is usdrecord's default: a light at the camera that lights what the camera sees
and is never seen itself. usdrecord's camera light is Storm's simple positional light at the
camera without distance falloff (diffuse 1, so a white diffuse surface facing the camera shows
as white); other Hydra delegates receive it as a light sprim at the camera. Penumbra's is a
normalized DistantLight whose light travels along the camera's view axis with irradiance π:
a white Lambertian surface facing the camera has radiance 1 whatever the scene's scale, as
under Storm's light. Off the view axis the two differ by the angle between the view axis and
the direction to the camera (a few degrees in a normal field of view).

``"dome"`` is a uniform white dome of radiance 1; ``"none"`` leaves the stage dark except for
its emissive surfaces (usdrecord's ``--disableCameraLight``).
"""

from __future__ import annotations

import logging
import math
from typing import Literal

import numpy as np
from pxr import Usd, UsdGeom

logger = logging.getLogger("penumbra")

DefaultLight = Literal["camera", "dome", "none"]
DEFAULT_LIGHTS: tuple[str, ...] = ("camera", "dome", "none")
DEFAULT_LIGHT_ID = "/PenumbraDefaultLight"
"""Id of the default light in the render delegate (never a prim of the stage)."""
CAMERA_LIGHT_IRRADIANCE = math.pi
"""Irradiance of the camera light on a surface facing the camera (radiance 1 off white)."""

_SPRIM_TYPES = {"camera": "distantLight", "dome": "domeLight"}


def check_default_light(kind: str) -> None:
    """Raise ``ValueError`` unless ``kind`` is one of :data:`DEFAULT_LIGHTS`."""
    if kind not in DEFAULT_LIGHTS:
        raise ValueError(f"default_light must be one of {DEFAULT_LIGHTS}, not {kind!r}")


class DefaultLightManager:
    """Keeps the render delegate's default light in step with the stage and the render."""

    def __init__(self, core, stage_name: str):
        self._core = core
        self._stage_name = stage_name
        self._kind: str = "none"  # what is in the delegate now
        self._reported: set[str] = set()

    @property
    def kind(self) -> str:
        """The default light now in the delegate ("none" when there is none)."""
        return self._kind

    def update(
        self,
        kind: str,
        stage_has_lights: bool,
        camera: Usd.Prim,
        time: Usd.TimeCode,
        dome_light_visibility: bool,
    ) -> None:
        """Insert, change or remove the default light: ``kind`` when the stage has no lights
        of its own, else none. The camera light follows ``camera`` at ``time``."""
        wanted = "none" if stage_has_lights else kind
        if wanted != self._kind:
            if self._kind != "none":
                self._core.remove_prim(DEFAULT_LIGHT_ID)
            if wanted != "none":
                self._core.insert_sprim(_SPRIM_TYPES[wanted], DEFAULT_LIGHT_ID)
            self._kind = wanted
            self._report(wanted)
        if wanted == "camera":
            self._core.set_light(
                DEFAULT_LIGHT_ID,
                intensity=CAMERA_LIGHT_IRRADIANCE,
                normalize=True,
                angle=0.0,
                cameraVisible=False,
            )
            world = UsdGeom.Xformable(camera).ComputeLocalToWorldTransform(time)
            self._core.set_transform(DEFAULT_LIGHT_ID, np.array(world, dtype=np.float64))
        elif wanted == "dome":
            self._core.set_light(
                DEFAULT_LIGHT_ID, intensity=1.0, cameraVisible=dome_light_visibility
            )

    def _report(self, kind: str) -> None:
        # A default, not a problem with the stage: information, not a warning; once per kind.
        if kind == "none" or kind in self._reported:
            return
        self._reported.add(kind)
        what = (
            "a camera light"
            if kind == "camera"
            else "a uniform white dome light (radiance 1)"
        )
        logger.info("%s: the stage has no lights; rendering under %s", self._stage_name, what)
