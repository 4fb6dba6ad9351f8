"""The material inputs are defined once, by the renderer's table (renderer/material_inputs.h,
``_core.material_inputs()``): the scene delegate's sets of inputs must be that
table's, and the table's UsdPreviewSurface inputs must be the schema's."""

from __future__ import annotations

import math

import pytest
from pxr import Sdr

from penumbra import _core
from penumbra.usd import material, material_data, materialx

TABLE = _core.material_inputs()
READ_FROM_PREVIEW_SURFACE = {"UsdPreviewSurface", "UsdPreviewSurface extension"}


def test_the_scene_delegate_reads_the_tables_inputs_from_a_preview_surface() -> None:
    read = [i for i in TABLE if i.origin in READ_FROM_PREVIEW_SURFACE]
    assert material_data.INPUTS == tuple(i.name for i in read if i.constant)
    assert material_data.CONNECTABLE == {i.name for i in read if i.connectable}
    assert material._VECTOR_INPUTS == {i.name for i in read if i.kind == "vector"}


def test_materialx_surfaces_may_drive_every_connectable_input() -> None:
    assert materialx._CONNECTABLE == {i.name for i in TABLE if i.connectable}
    assert materialx._VECTOR_PARAMS == {i.name for i in TABLE if i.kind == "vector"}


def test_the_tables_preview_surface_inputs_are_the_schemas() -> None:
    node = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface")
    if not node:
        pytest.skip("UsdPreviewSurface is not in the shader registry")
    kinds = {"float": "float", "color": "vector", "normal": "vector", "int": "bool"}
    for entry in TABLE:
        schema_input = node.GetShaderInput(entry.name)
        if entry.origin == "UsdPreviewSurface":
            assert schema_input is not None, entry.name
            assert kinds[str(schema_input.GetType())] == entry.kind, entry.name
        else:
            assert schema_input is None, entry.name
            assert entry.name.startswith("penumbra:"), entry.name


def test_set_material_takes_every_input_of_the_table() -> None:
    delegate = _core.RenderDelegate()
    delegate.insert_sprim("material", "/m")
    samples = {"float": 0.5, "vector": (0.5, 0.5, 0.5), "bool": 1, "token": "standardSurface"}
    for entry in TABLE:
        if entry.constant:
            delegate.set_material("/m", {entry.name: samples[entry.kind]})
        else:
            with pytest.raises(ValueError, match=f"unknown UsdPreviewSurface input '{entry.name}'"):
                delegate.set_material("/m", {entry.name: samples[entry.kind]})
        if entry.connectable:
            delegate.set_material("/m", {entry.name: {"primvar": "st"}})
        else:
            with pytest.raises(ValueError, match=f"unknown connectable input '{entry.name}'"):
                delegate.set_material("/m", {entry.name: {"primvar": "st"}})
        if entry.must_be_finite:
            nan = (math.nan,) * 3 if entry.kind == "vector" else math.nan
            with pytest.raises(ValueError, match=f"{entry.name} must be finite"):
                delegate.set_material("/m", {entry.name: nan})
