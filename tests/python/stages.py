"""Builders of tiny stages for the Python tests (scene-linear, metersPerUnit 1, Y up)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

import penumbra
from penumbra.usd import implicit

SCENES = Path(__file__).resolve().parents[1] / "assets"
"""Test scenes kept in the repository (tests/assets: cornell.usda and usd-wg with its licences)."""
CORNELL = SCENES / "cornell.usda"


def new_stage(path: Path | None = None) -> Usd.Stage:
    """An empty stage (in memory, or a new file at ``path``) rendering time code 1."""
    stage = Usd.Stage.CreateNew(str(path)) if path else Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(1)
    return stage


def add_camera(
    stage: Usd.Stage,
    path: str = "/cam",
    translate=(0.0, 0.0, 5.0),
    rotate_x: float = 0.0,
    focal_length: float = 5.0,
    aperture=(4.0, 4.0),
) -> UsdGeom.Camera:
    """A pinhole camera; with the defaults it sees the square [-2, 2]² of the z = 0 plane."""
    camera = UsdGeom.Camera.Define(stage, path)
    camera.CreateFocalLengthAttr(focal_length)
    camera.CreateHorizontalApertureAttr(aperture[0])
    camera.CreateVerticalApertureAttr(aperture[1])
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.01, 1000.0))
    camera.AddTranslateOp().Set(Gf.Vec3d(*translate))
    if rotate_x:
        camera.AddRotateXOp().Set(rotate_x)
    return camera


def add_quad(
    stage: Usd.Stage,
    path: str,
    center=(0.0, 0.0, 0.0),
    half_size: float = 1.0,
    color=None,
    facing: str = "z",
) -> UsdGeom.Mesh:
    """A square facing +Z (in the XY plane) or +Y (``facing="y"``, in the XZ plane), wound
    counter-clockwise seen from the front, single-sided unless told otherwise."""
    s = half_size
    if facing == "z":
        corners = [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)]
    else:
        corners = [(-s, 0, -s), (-s, 0, s), (s, 0, s), (s, 0, -s)]
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr([Gf.Vec3f(*c) for c in corners])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateDoubleSidedAttr(False)
    if color is not None:
        mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([Gf.Vec3f(*color)])
    mesh.AddTranslateOp().Set(Gf.Vec3d(*center))
    return mesh


def add_instance(stage: Usd.Stage, path: str, prototype: str, translate=(0.0, 0.0, 0.0)) -> Usd.Prim:
    """An instanceable Xform referencing ``prototype`` (a prim of the stage)."""
    xform = UsdGeom.Xform.Define(stage, path)
    xform.AddTranslateOp().Set(Gf.Vec3d(*translate))
    xform.GetPrim().GetReferences().AddInternalReference(prototype)
    xform.GetPrim().SetInstanceable(True)
    return xform.GetPrim()


def add_instancer(stage: Usd.Stage, path: str, prototype: str, positions) -> UsdGeom.PointInstancer:
    """A point instancer placing copies of ``prototype`` (one prototype) at ``positions``."""
    instancer = UsdGeom.PointInstancer.Define(stage, path)
    instancer.CreatePrototypesRel().SetTargets([prototype])
    instancer.CreatePositionsAttr(Vt.Vec3fArray(positions))
    instancer.CreateProtoIndicesAttr(Vt.IntArray([0] * len(positions)))
    return instancer


def add_distant_light(stage: Usd.Stage, path: str = "/sun", intensity: float = 3.0):
    """A distant light shining along −Z (onto quads facing +Z); normalized, so that the
    irradiance of a surface facing it is ``intensity``."""
    light = UsdLux.DistantLight.Define(stage, path)
    light.CreateIntensityAttr(intensity)
    light.CreateNormalizeAttr(True)
    light.CreateAngleAttr(0.5)
    return light


def add_preview_material(stage: Usd.Stage, path: str, **inputs) -> UsdShade.Material:
    """A material whose surface is a UsdPreviewSurface with the given inputs."""
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, value in inputs.items():
        type_name = (
            Sdf.ValueTypeNames.Color3f
            if isinstance(value, tuple)
            else (Sdf.ValueTypeNames.Int if isinstance(value, int) else Sdf.ValueTypeNames.Float)
        )
        shader.CreateInput(name, type_name).Set(value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def bind(mesh: UsdGeom.Mesh, material: UsdShade.Material) -> None:
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def bind_through_a_collection(
    stage: Usd.Stage, path: str, material: UsdShade.Material
) -> Usd.CollectionAPI:
    """An empty collection ``/Sets.collection:painted`` and, on prim ``path``, a
    collection-based binding of ``material`` to what it will hold (stronger than descendants)."""
    collection = Usd.CollectionAPI.Apply(stage.DefinePrim("/Sets"), "painted")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath(path)).Bind(
        collection, UsdShade.Material(material), "painted",
        UsdShade.Tokens.strongerThanDescendants,
    )
    return collection


def assert_live_edit_renders_as_fresh(stage: Usd.Stage, edit, **render) -> None:
    """Render ``stage``, apply ``edit()``, render again with the same Renderer: the image
    changed and equals a fresh Renderer's of the edited stage."""
    renderer = penumbra.Renderer(stage)
    before = renderer.render(**render)["color"]
    edit()
    live = renderer.render(**render)["color"]
    fresh = penumbra.Renderer(stage).render(**render)["color"]
    assert not np.array_equal(before, fresh)
    np.testing.assert_array_equal(live, fresh)


def add_primvar_emission_material(stage: Usd.Stage, path: str, primvar: str) -> UsdShade.Material:
    """A black, non-reflecting UsdPreviewSurface whose emissiveColor a UsdPrimvarReader_float3
    reads from the float3 primvar `primvar`: the image shows the primvar itself."""
    material = UsdShade.Material.Define(stage, path)
    surface = UsdShade.Shader.Define(stage, f"{path}/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0))
    surface.CreateInput("specularColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0))
    surface.CreateInput("useSpecularWorkflow", Sdf.ValueTypeNames.Int).Set(1)
    reader = UsdShade.Shader.Define(stage, f"{path}/Reader")
    reader.CreateIdAttr("UsdPrimvarReader_float3")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set(primvar)
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        reader.CreateOutput("result", Sdf.ValueTypeNames.Float3)
    )
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def lit_quad_stage(path: Path | None = None) -> Usd.Stage:
    """A camera looking at a grey quad facing it, lit by a distant light: the quad fills the
    central half of the image."""
    stage = new_stage(path)
    add_camera(stage)
    add_quad(stage, "/World/quad")
    add_distant_light(stage)
    return stage


def pixel(image, u: float, v: float):
    """The RGB of the pixel at fractional position (u, v) (0..1 from the top-left)."""
    color = image["color"] if hasattr(image, "keys") else image
    h, w = color.shape[:2]
    return color[min(h - 1, int(v * h)), min(w - 1, int(u * w)), :3]


def add_sphere_mesh(
    stage: Usd.Stage,
    path: str,
    center=(0.0, 0.0, 0.0),
    radius: float = 1.0,
    rings: int = 12,
    sectors: int = 24,
) -> UsdGeom.Mesh:
    """A UV sphere tessellated as a UsdGeomMesh (quads, triangles at the poles; Penumbra's own
    implicit-sphere tessellation, without its normals), its points around the origin and placed
    by a translate op at ``center``."""
    generated = implicit.sphere(radius, segments=sectors, rings=rings)
    points, counts, indices = generated.points, generated.counts, generated.indices
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.AddTranslateOp().Set(Gf.Vec3d(*center))
    return mesh


def emitter_stage(meters_per_unit: float = 1.0, path: Path | None = None) -> Usd.Stage:
    """An empty stage for emitters on black: a distant light of intensity 0 keeps the default
    dome away, so with ``max_path_depth=0`` only emissive surfaces show."""
    stage = new_stage(path)
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    UsdLux.DistantLight.Define(stage, "/off").CreateIntensityAttr(0.0)
    add_preview_material(
        stage, "/Looks/glow", diffuseColor=(0.0, 0.0, 0.0), emissiveColor=(1.0, 1.0, 1.0)
    )
    return stage


def add_emissive_sphere(stage: Usd.Stage, path: str, center, radius: float) -> UsdGeom.Mesh:
    """A small white emissive sphere (radiance 1) bound to ``/Looks/glow`` of
    :func:`emitter_stage`."""
    mesh = add_sphere_mesh(stage, path, center, radius)
    bind(mesh, UsdShade.Material(stage.GetPrimAtPath("/Looks/glow")))
    return mesh


def render_with_warnings(stage: Usd.Stage, width: int) -> tuple[np.ndarray, list[str]]:
    """The colour image of ``stage`` through ``/cam`` (``width`` pixels wide, 4 spp, seed 1)
    and the Penumbra warnings rendering it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = penumbra.Renderer(stage).render(camera="/cam", width=width, samples=4, seed=1)
    messages = [str(w.message) for w in caught if issubclass(w.category, penumbra.PenumbraWarning)]
    return np.asarray(image["color"]), messages


def covers(image: np.ndarray, x: float, y: float) -> bool:
    """Whether something is seen at point (x, y) of the z = 0 plane in an image through the
    camera of :func:`add_camera` (which sees [-2, 2]²)."""
    height, width = image.shape[:2]
    return image[int((2 - y) / 4 * height), int((x + 2) / 4 * width), 3] == 1
