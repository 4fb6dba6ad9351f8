"""penumbra._core directly: render buffers bound to a render pass; batched setters."""

from __future__ import annotations

import numpy as np
import pytest

from penumbra import _core


def quad_under_sky() -> _core.RenderDelegate:
    """A 2x2 quad at z = 0 under a white dome, seen by camera /cam from z = 5."""
    delegate = _core.RenderDelegate()
    delegate.insert_rprim("mesh", "/quad")
    delegate.set_mesh_topology("/quad", np.array([4], np.int32), np.array([0, 1, 2, 3], np.int32))
    delegate.set_mesh_points("/quad", np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], np.float32))
    delegate.insert_sprim("camera", "/cam")
    delegate.set_camera("/cam", focal_length=5, horizontal_aperture=4, vertical_aperture=4)
    delegate.set_transform("/cam", np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 5, 1]], float))
    delegate.insert_sprim("domeLight", "/sky")
    return delegate


def test_render_buffers_receive_bound_aovs():
    delegate = quad_under_sky()
    delegate.insert_bprim("renderBuffer", "/depth")
    delegate.allocate_render_buffer("/depth", 8, 8)
    render_pass = _core.RenderPass(delegate, "/cam", 8, 8)
    render_pass.set_aov_bindings({"Z": "/depth"})
    render_pass.execute(1)
    depth, converged = delegate.render_buffer("/depth")
    assert depth.shape == (8, 8, 1) and not converged
    np.testing.assert_array_equal(depth, render_pass.aov("Z"))
    assert depth[4, 4, 0] == pytest.approx(5.0)
    with pytest.raises(ValueError, match="unknown AOV"):
        render_pass.set_aov_bindings({"bogus": "/depth"})
    with pytest.raises(ValueError, match="not accumulated"):
        render_pass.set_aov_bindings({"normal": "/depth"})
    with pytest.raises(KeyError, match="/nowhere"):
        render_pass.set_aov_bindings({"color": "/nowhere"})


def _quad_scene(delegate, batched: bool):
    """Two quads at depths 4 and 6 seen by a camera, sent one setter call per prim or batched."""
    corners = np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], np.float32)
    ids = ["/near", "/far"]
    matrices = [np.eye(4), np.eye(4)]
    matrices[0][3, 2], matrices[1][3, 2] = 1.0, -1.0
    counts, indices = np.array([4], np.int32), np.array([0, 1, 2, 3], np.int32)
    color = np.array([[0.8, 0.2, 0.2]], np.float32)
    no_normals = np.empty((0, 3), np.float32)
    mesh = (counts, indices, False, "none", corners, True, color, "constant")
    mesh += (no_normals, "vertex", {})
    names = ("face_vertex_counts", "face_vertex_indices", "left_handed", "subdivision_scheme",
             "points", "double_sided", "display_color", "display_color_interpolation",
             "normals", "normals_interpolation", "primvars")
    if batched:
        delegate.insert_rprims("mesh", ids)
        records = [_core.MeshRecord(prim_id, **dict(zip(names, mesh))) for prim_id in ids]
        delegate.set_meshes(records)
        delegate.set_transforms(ids, matrices)
        delegate.set_visibilities(ids, [False, True])
        delegate.set_mesh_materials(ids, ["", ""])
    else:
        for prim_id, matrix, visible in zip(ids, matrices, (False, True)):
            delegate.insert_rprim("mesh", prim_id)
            delegate.set_mesh(prim_id, **dict(zip(names, mesh)))
            delegate.set_transform(prim_id, matrix)
            delegate.set_visible(prim_id, visible)
            delegate.set_mesh_material(prim_id, "")
    delegate.insert_sprim("camera", "/cam")
    delegate.set_camera("/cam", focal_length=5, horizontal_aperture=4, vertical_aperture=4)
    delegate.set_transform("/cam", np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 5, 1]], float))
    delegate.insert_sprim("domeLight", "/sky")


def test_batched_setters_match_one_call_per_prim():
    images = []
    for batched in (False, True):
        delegate = _core.RenderDelegate()
        _quad_scene(delegate, batched)
        render_pass = _core.RenderPass(delegate, "/cam", 8, 8)
        render_pass.execute(2)
        images.append(render_pass.aov("Z"))
    np.testing.assert_array_equal(images[0], images[1])
    assert images[1][4, 4, 0] == pytest.approx(6.0)  # the far quad: the near one is hidden


def test_batched_setters_reject_lists_of_different_lengths():
    delegate = _core.RenderDelegate()
    delegate.insert_rprims("mesh", ["/a", "/b"])
    with pytest.raises(ValueError, match="as many values"):
        delegate.set_visibilities(["/a", "/b"], [True])
    with pytest.raises(KeyError, match="/missing"):
        delegate.set_transforms(["/missing"], [np.eye(4)])
    with pytest.raises(TypeError, match="MeshRecord"):
        delegate.set_meshes([("/a", np.array([3], np.int32))])


def test_raw_throughput_counts_the_rays_one_sample_per_pixel_traces():
    """measure_raw_throughput (bench/quality.py's ray-cost table) times Embree on the rays the
    render settings trace: one camera ray per pixel, then a shadow ray to the sky and a bounce
    from each pixel that sees the quad; more with branching."""
    delegate = quad_under_sky()
    counts = []
    for branches in (1, 3):
        delegate.set_render_setting("indirectSamples", branches)
        raw = _core.RenderPass(delegate, "/cam", 8, 8).measure_raw_throughput()
        assert raw["path"] > 0 and raw["primary"] > 0
        counts.append(raw["path_rays"])
    assert 64 < counts[0] < counts[1]
