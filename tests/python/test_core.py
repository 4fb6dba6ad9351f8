"""penumbra._core directly: render buffers bound to a render pass."""

from __future__ import annotations

import numpy as np
import pytest

from penumbra import _core


def test_render_buffers_receive_bound_aovs():
    delegate = _core.RenderDelegate()
    delegate.insert_rprim("mesh", "/quad")
    delegate.set_mesh_topology("/quad", np.array([4], np.int32), np.array([0, 1, 2, 3], np.int32))
    delegate.set_mesh_points("/quad", np.array([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], np.float32))
    delegate.insert_sprim("camera", "/cam")
    delegate.set_camera("/cam", focal_length=5, horizontal_aperture=4, vertical_aperture=4)
    delegate.set_transform("/cam", np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 5, 1]], float))
    delegate.insert_sprim("domeLight", "/sky")
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
