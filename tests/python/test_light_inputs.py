"""The light inputs table: the inputs the Python scene delegate reads from a UsdLux light are
the render delegate's (``_core.light_inputs()``, plugin/src/light_types.cpp), so the two cannot
drift apart."""

from __future__ import annotations

from pxr import Sdf, Usd, UsdGeom, UsdLux

from penumbra import _core
from penumbra.usd import lights
from penumbra.usd.sampling import SampleReader
from stages import new_stage

_SENT_TYPES = {"float": float, "color": tuple, "bool": bool, "asset": str}
"""The Python type each kind of input is sent as."""


class RecordingCore:
    """Keeps the inputs sent by set_light and set_mesh_light; set_light's go on to a render
    delegate too, which refuses an input it does not know."""

    def __init__(self) -> None:
        self.delegate = _core.RenderDelegate()
        self.sent: dict[str, dict] = {}

    def set_light(self, prim_id: str, **params) -> None:
        self.sent[prim_id] = params
        self.delegate.set_light(prim_id, **params)

    def set_mesh_light(self, prim_id: str, enabled: bool, **params) -> None:
        self.sent[prim_id] = params


def _table_inputs(sprim_type: str | None) -> dict[str, _core.LightInput]:
    """The table's inputs of a light of ``sprim_type`` with every applied schema (a mesh light's
    when ``None``)."""
    if sprim_type is None:
        return {i.name: i for i in _core.light_inputs()
                if i.origin in ("LightAPI", "ShapingAPI", "ShadowAPI")}
    return {
        i.name: i
        for i in _core.light_inputs()
        if i.origin != "light schema" or sprim_type in i.light_types
    }


def test_the_inputs_read_are_the_tables():
    stage = new_stage()
    core = RecordingCore()
    reader = SampleReader(Usd.TimeCode(1))
    for light in _core.light_types():
        path = f"/{light.sprim_type}"
        prim = getattr(UsdLux, light.schema).Define(stage, path).GetPrim()
        UsdLux.ShapingAPI.Apply(prim)
        UsdLux.ShadowAPI.Apply(prim)
        core.delegate.insert_sprim(light.sprim_type, path)
        lights.sync_light(core, prim, reader, warn=lambda message: None)
        table = _table_inputs(light.sprim_type)
        sent = core.sent[path]
        if "texture:file" not in table:  # sent to every light: empty where its schema has none
            assert sent.pop("texture:file") == ""
        assert set(sent) == set(table), light.sprim_type
        for name, value in sent.items():
            assert isinstance(value, _SENT_TYPES[table[name].kind]), (path, name)
    mesh = UsdGeom.Mesh.Define(stage, "/emitter").GetPrim()
    UsdLux.MeshLightAPI.Apply(mesh)
    lights.sync_mesh_light(core, mesh, "/emitter", reader, warn=lambda message: None)
    sent = dict(core.sent["/emitter"])
    assert sent.pop("shaping:ies:file") == ""  # sent always, resolved: none without ShapingAPI
    assert list(sent) == list(lights._COMMON_INPUTS)  # no schema applied
    UsdLux.ShapingAPI.Apply(mesh)
    UsdLux.ShadowAPI.Apply(mesh)
    lights.sync_mesh_light(core, mesh, "/emitter", reader, warn=lambda message: None)
    sent = dict(core.sent["/emitter"])
    assert sent.pop("shaping:ies:file") == ""
    assert list(sent) == [name for name in _table_inputs(None) if name != "shaping:ies:file"]


def test_the_derived_lists_keep_their_order():
    """lights.py reads the inputs in the table's order: UsdLuxLightAPI's, then the shape's, then
    the applied schemas'."""
    assert lights._COMMON_INPUTS == (
        "color",
        "intensity",
        "exposure",
        "normalize",
        "enableColorTemperature",
        "colorTemperature",
        "diffuse",
        "specular",
    )
    assert {sprim_type: shape for sprim_type, _, shape in lights._LIGHTS} == {
        "rectLight": ("width", "height"),
        "diskLight": ("radius",),
        "sphereLight": ("radius", "treatAsPoint"),
        "cylinderLight": ("radius", "length", "treatAsLine"),
        "distantLight": ("angle",),
        "domeLight": (),
    }
    assert lights._SHAPING_INPUTS == (
        "shaping:cone:angle",
        "shaping:cone:softness",
        "shaping:focus",
        "shaping:focusTint",
        "shaping:ies:angleScale",
        "shaping:ies:normalize",
    )
    assert lights._SHADOW_INPUTS == ("shadow:enable",)
    assert lights._COLOR_INPUTS == ("color", "shaping:focusTint")


def _has_attribute(schema: type, name: str) -> bool:
    """Whether ``schema`` itself (not a schema it includes) has the attribute of input ``name``."""
    return bool({f"inputs:{name}", name} & set(schema.GetSchemaAttributeNames(False)))


def test_every_usdlux_input_is_its_schemas_attribute():
    """Each input's name is the UsdLux attribute's without ``inputs:`` (treatAsPoint and
    treatAsLine have none), of the kind the table says, on the schemas the table says."""
    value_types = {
        "float": Sdf.ValueTypeNames.Float,
        "color": Sdf.ValueTypeNames.Color3f,
        "bool": Sdf.ValueTypeNames.Bool,
        "asset": Sdf.ValueTypeNames.Asset,
    }
    stage = new_stage()
    schemas = {
        "LightAPI": [UsdLux.LightAPI],
        "ShapingAPI": [UsdLux.ShapingAPI],
        "ShadowAPI": [UsdLux.ShadowAPI],
        "light schema": [getattr(UsdLux, light.schema) for light in _core.light_types()],
    }
    for light_input in _core.light_inputs():
        if light_input.origin == "front end":
            assert light_input.name == "cameraVisible"
            continue
        name = light_input.name
        found = [schema for schema in schemas[light_input.origin] if _has_attribute(schema, name)]
        assert found, light_input.name
        for schema in found:
            if light_input.origin == "light schema":
                holder = schema.Define(stage, f"/{schema.__name__}")
            else:
                holder = schema.Apply(stage.DefinePrim(f"/{schema.__name__}"))
            attr = lights._getter(holder, light_input.name)
            assert attr.GetName() in (f"inputs:{light_input.name}", light_input.name)
            assert attr.GetTypeName() == value_types[light_input.kind], light_input.name
        holders = [
            light.sprim_type
            for light, schema in zip(_core.light_types(), schemas["light schema"])
            if _has_attribute(schema, name)
        ]
        expected = light_input.light_types if light_input.origin == "light schema" else []
        assert sorted(holders) == sorted(expected), name
