"""Expected renders of textured UsdPreviewSurface stages, computed without the renderer.

A small reference "rasteriser" for tests of UsdUVTexture / UsdPrimvarReader_float2 /
UsdTransform2d: it reads the stage with pxr only, decodes the PNG textures itself (zlib, no
OIIO), and evaluates each mesh's diffuseColor network per the UsdPreviewSurface spec
(https://openusd.org/release/spec_usdpreviewsurface.html):

- st comes from the primvar named by the UsdPrimvarReader_float2's ``varname`` (vertex,
  varying, faceVarying or constant; indexed or not), interpolated linearly over triangles;
- UsdTransform2d: ``result = in * scale * rotate * translation`` (row vectors; rotation in
  degrees, counter-clockwise), i.e. ``st' = R(rotation) · (scale ⊙ st) + translation``;
- UsdUVTexture: st (0, 0) is the bottom-left corner of the image, (1, 1) the top-right; texels
  are decoded to linear (sRGB transfer function for ``sRGB``, and for ``auto`` on 8-bit images)
  and then ``rgb * scale + bias``; ``wrapS``/``wrapT`` repeat, clamp, mirror or black;
  bilinear lookups between texel centres.

Only orthographic cameras looking down −Z are supported (``OrthoView``): each pixel maps to a
world-space (x, y) and the visible surface is the one with the largest z there. Pixels are
supersampled with the renderer's pixel filter (a Gaussian of σ = 0.5 px truncated at 1.5 px).

``Conventions`` lets a test switch single conventions off (flipped t, swapped s/t, another
transform order, …) to show that its assertions tell the right convention from wrong ones.
"""

from __future__ import annotations

import functools
import math
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

FILTER_RADIUS = 1.5  # px, the renderer's pixel filter (renderer/include/penumbra/filter.h)
FILTER_SIGMA = 0.5


# --------------------------------------------------------------------------------------------
# PNG decoding (8-bit, non-interlaced; grey, RGB, palette, grey+alpha, RGBA)


@functools.lru_cache(maxsize=16)
def read_png(path: str | Path) -> np.ndarray:
    """The encoded 8-bit values of a PNG as float64 (H, W, 4) in [0, 1] (no colour transform),
    row 0 the top of the image."""
    data = Path(path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, palette, transparency = 8, b"", None, None
    width = height = depth = ctype = interlace = None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            palette = np.frombuffer(body, np.uint8).reshape(-1, 3)
        elif kind == b"tRNS":
            transparency = np.frombuffer(body, np.uint8)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if depth != 8 or interlace != 0:
        raise ValueError(f"{path}: only 8-bit non-interlaced PNGs are supported")
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[ctype]
    raw = np.frombuffer(zlib.decompress(idat), np.uint8)
    stride = width * channels
    rows = raw.reshape(height, stride + 1)
    out = np.zeros((height, stride), np.int32)
    prev = np.zeros(stride, np.int32)
    for y in range(height):
        kind, line = rows[y, 0], rows[y, 1:].astype(np.int32)
        if kind == 0:
            cur = line
        elif kind == 1:  # Sub: a running sum per channel
            cur = (np.cumsum(line.reshape(width, channels), axis=0) & 0xFF).ravel()
        elif kind == 2:  # Up
            cur = (line + prev) & 0xFF
        elif kind in (3, 4):  # Average, Paeth: sequential, on Python ints
            a, b, values = line.tolist(), prev.tolist(), [0] * stride
            for x in range(stride):
                left = values[x - channels] if x >= channels else 0
                up = b[x]
                if kind == 3:
                    pred = (left + up) >> 1
                else:
                    up_left = b[x - channels] if x >= channels else 0
                    p = left + up - up_left
                    pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                    pred = left if pa <= pb and pa <= pc else (up if pb <= pc else up_left)
                values[x] = (a[x] + pred) & 0xFF
            cur = np.array(values, np.int32)
        else:
            raise ValueError(f"{path}: bad PNG filter type {kind}")
        out[y] = cur
        prev = cur
    pixels = out.reshape(height, width, channels)
    if ctype == 3:
        alpha = np.full(len(palette), 255)
        if transparency is not None:
            alpha[: len(transparency)] = transparency
        rgba = np.concatenate([palette, alpha[:, None]], axis=1)[pixels[..., 0]]
    elif ctype == 0:
        rgba = np.concatenate([np.repeat(pixels, 3, axis=2), np.full_like(pixels, 255)], axis=2)
    elif ctype == 4:
        rgba = np.concatenate([np.repeat(pixels[..., :1], 3, axis=2), pixels[..., 1:]], axis=2)
    elif ctype == 2:
        rgba = np.concatenate([pixels, np.full_like(pixels[..., :1], 255)], axis=2)
    else:
        rgba = pixels
    return rgba.astype(np.float64) / 255.0


def srgb_to_linear(v):
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


# --------------------------------------------------------------------------------------------
# Conventions and shading networks


@dataclass(frozen=True)
class Conventions:
    """The spec's conventions (the defaults) and switches for deliberately wrong ones."""

    flip_t: bool = False  # wrong: t = 0 at the top row of the image
    swap_st: bool = False  # wrong: s indexes rows, t columns
    transform_order: str = "SRT"  # spec: scale, then rotate, then translate; e.g. "TRS" wrong
    clockwise: bool = False  # wrong: rotation clockwise
    ignore_transform: bool = False  # wrong: UsdTransform2d skipped
    decode_srgb: bool = True  # wrong when False: sRGB textures used as if linear
    apply_scale_bias: bool = True  # wrong when False: UsdUVTexture scale and bias ignored
    wrap_override: str | None = None  # e.g. "repeat" everywhere instead of the authored wraps


SPEC = Conventions()


@dataclass
class Texture:
    path: str
    texels: np.ndarray | None  # encoded values, (H, W, 4), or None when unreadable
    srgb: bool
    scale: np.ndarray
    bias: np.ndarray
    fallback: np.ndarray
    wrap_s: str
    wrap_t: str
    varname: str
    transform: tuple[np.ndarray, float, np.ndarray] | None  # (scale, degrees, translation)

    @functools.cached_property
    def linear(self) -> np.ndarray:
        """RGB decoded to linear by the texture's colour space."""
        rgb = self.texels[..., :3]
        return srgb_to_linear(rgb) if self.srgb else rgb


def _value(shader: UsdShade.Shader, name: str, default):
    attr = shader.GetInput(name)
    if not attr or not attr.GetAttr().HasAuthoredValue():
        return default
    return attr.Get()


def _source_shader(shader_input: UsdShade.Input) -> UsdShade.Shader | None:
    if not shader_input:
        return None
    sources = shader_input.GetConnectedSources()[0]
    if not sources:
        return None
    return UsdShade.Shader(sources[0].source.GetPrim())


def _shader_id(shader: UsdShade.Shader) -> str:
    return str(shader.GetIdAttr().Get() or "")


def diffuse_network(material: UsdShade.Material):
    """(UsdPreviewSurface shader, Texture or None, constant diffuseColor as float64[3])."""
    surface = material.ComputeSurfaceSource()[0]
    if not surface or _shader_id(surface) != "UsdPreviewSurface":
        raise ValueError(f"{material.GetPath()}: no UsdPreviewSurface")
    diffuse = surface.GetInput("diffuseColor")
    constant = np.array(_value(surface, "diffuseColor", Gf.Vec3f(0.18)), dtype=np.float64)
    texture_shader = _source_shader(diffuse)
    if texture_shader is None:
        return surface, None, constant
    if _shader_id(texture_shader) != "UsdUVTexture":
        raise ValueError(f"{texture_shader.GetPath()}: expected a UsdUVTexture")
    file_attr = texture_shader.GetInput("file").Get()
    path = file_attr.resolvedPath if file_attr is not None else ""
    texels = read_png(path) if path and Path(path).is_file() else None
    # sourceColorSpace (spec 2.3+), else the legacy isSRGB token; "auto": sRGB for 8-bit images.
    space = _value(texture_shader, "sourceColorSpace", None)
    if space is None:
        space = _value(texture_shader, "isSRGB", "auto")
    srgb = str(space) in ("sRGB", "auto", "True", "1")
    transform = None
    st_source = _source_shader(texture_shader.GetInput("st"))
    if st_source is not None and _shader_id(st_source) == "UsdTransform2d":
        transform = (
            np.array(_value(st_source, "scale", Gf.Vec2f(1, 1)), dtype=np.float64),
            float(_value(st_source, "rotation", 0.0)),
            np.array(_value(st_source, "translation", Gf.Vec2f(0, 0)), dtype=np.float64),
        )
        st_source = _source_shader(st_source.GetInput("in"))
    if st_source is None or not _shader_id(st_source).startswith("UsdPrimvarReader"):
        raise ValueError(f"{texture_shader.GetPath()}: st is not read from a primvar")
    texture = Texture(
        path=path,
        texels=texels,
        srgb=srgb,
        scale=np.array(_value(texture_shader, "scale", Gf.Vec4f(1, 1, 1, 1)), dtype=np.float64),
        bias=np.array(_value(texture_shader, "bias", Gf.Vec4f(0, 0, 0, 0)), dtype=np.float64),
        fallback=np.array(
            _value(texture_shader, "fallback", Gf.Vec4f(0, 0, 0, 1)), dtype=np.float64
        ),
        wrap_s=str(_value(texture_shader, "wrapS", "useMetadata")),
        wrap_t=str(_value(texture_shader, "wrapT", "useMetadata")),
        varname=str(_value(st_source, "varname", "st")),
        transform=transform,
    )
    return surface, texture, constant


def transform_st(st: np.ndarray, texture: Texture, conv: Conventions = SPEC) -> np.ndarray:
    """UsdTransform2d applied to st (…, 2)."""
    if texture.transform is None or conv.ignore_transform:
        return st
    scale, degrees, translation = texture.transform
    angle = math.radians(-degrees if conv.clockwise else degrees)
    c, s = math.cos(angle), math.sin(angle)

    def rotate(v):
        return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)

    out = st
    for step in conv.transform_order:
        if step == "S":
            out = out * scale
        elif step == "R":
            out = rotate(out)
        else:
            out = out + translation
    return out


def _wrap(coord: np.ndarray, size: int, mode: str):
    """Integer texel indices (possibly out of range for "black") and an in-range mask."""
    if mode == "repeat":
        return np.mod(coord, size), np.ones(coord.shape, bool)
    if mode == "mirror":
        period = np.mod(coord, 2 * size)
        return np.where(period < size, period, 2 * size - 1 - period), np.ones(coord.shape, bool)
    if mode == "black":
        inside = (coord >= 0) & (coord < size)
        return np.clip(coord, 0, size - 1), inside
    # clamp (and useMetadata without metadata: clamp is UsdUVTexture's fallback behaviour)
    return np.clip(coord, 0, size - 1), np.ones(coord.shape, bool)


def lookup(texture: Texture, st: np.ndarray, conv: Conventions = SPEC) -> np.ndarray:
    """Linear RGB (…, 3) of the texture (after scale and bias) at untransformed st (…, 2)."""
    st = transform_st(st, texture, conv)
    if texture.texels is None:
        rgb = np.broadcast_to(texture.fallback[:3], st.shape[:-1] + (3,)).copy()
        return rgb
    texels = texture.linear if conv.decode_srgb else texture.texels[..., :3]
    h, w = texels.shape[:2]
    s, t = st[..., 0], st[..., 1]
    if conv.swap_st:
        s, t = t, s
    x = s * w - 0.5
    y = (t if conv.flip_t else 1.0 - t) * h - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    wrap_s = conv.wrap_override or texture.wrap_s
    wrap_t = conv.wrap_override or texture.wrap_t
    result = 0.0
    for dx, dy, weight in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                           (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        xi, xin = _wrap(x0 + dx, w, wrap_s)
        yi, yin = _wrap(y0 + dy, h, wrap_t)
        value = texels[yi, xi] * (xin & yin)[..., None]
        result = result + weight * value
    if conv.apply_scale_bias:
        result = result * texture.scale[:3] + texture.bias[:3]
    return result


# --------------------------------------------------------------------------------------------
# Meshes and the orthographic reference render


@dataclass
class Surface:
    path: str
    material: str
    triangles: np.ndarray  # (T, 3, 3) world-space corners
    st: np.ndarray | None  # (T, 3, 2) st at the corners, None without a texture
    texture: Texture | None
    constant: np.ndarray  # diffuseColor when untextured


def _face_varying(primvar: UsdGeom.Primvar, counts, indices) -> np.ndarray | None:
    values = primvar.ComputeFlattened()
    if values is None or len(values) == 0:
        return None
    values = np.array(values, dtype=np.float64)
    interpolation = primvar.GetInterpolation()
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
        return values[indices]
    if interpolation == UsdGeom.Tokens.faceVarying:
        return values
    if interpolation == UsdGeom.Tokens.uniform:
        return np.repeat(values, counts, axis=0)
    return np.repeat(values[:1], len(indices), axis=0)


def collect_surfaces(stage: Usd.Stage, time=Usd.TimeCode.Default()) -> list[Surface]:
    """Every visible, active mesh with its world-space triangles and shading network."""
    cache = UsdGeom.XformCache(time)
    surfaces = []
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        if mesh.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            continue
        points = np.array(mesh.GetPointsAttr().Get(time), dtype=np.float64)
        matrix = np.array(cache.GetLocalToWorldTransform(prim))
        world = points @ matrix[:3, :3] + matrix[3, :3]
        counts = np.array(mesh.GetFaceVertexCountsAttr().Get(time))
        indices = np.array(mesh.GetFaceVertexIndicesAttr().Get(time))
        material = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
        texture, constant = None, np.array([0.5, 0.5, 0.5])
        if material:
            _, texture, constant = diffuse_network(material)
        st_fv = None
        if texture is not None:
            primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(texture.varname)
            st_fv = _face_varying(primvar, counts, indices) if primvar else None
        corners, st_corners, start = [], [], 0
        for count in counts:
            for k in range(1, count - 1):
                fv = [start, start + k, start + k + 1]
                corners.append(world[indices[fv]])
                if st_fv is not None:
                    st_corners.append(st_fv[fv])
            start += count
        surfaces.append(
            Surface(
                path=str(prim.GetPath()),
                material=str(material.GetPath()) if material else "",
                triangles=np.array(corners),
                st=np.array(st_corners) if st_fv is not None else None,
                texture=texture if st_fv is not None else None,
                constant=constant,
            )
        )
    return surfaces


@dataclass(frozen=True)
class OrthoView:
    """An orthographic camera at (cx, cy, +z) looking down −Z, seeing width × height scene
    units in pixels × rows pixels."""

    cx: float
    cy: float
    width: float
    height: float
    pixels: int

    @property
    def rows(self) -> int:
        return round(self.pixels * self.height / self.width)

    @property
    def pixel_size(self) -> float:
        return self.width / self.pixels

    def to_pixel(self, x, y):
        """Continuous image position (column, row; (0, 0) the top-left image corner)."""
        return ((x - (self.cx - self.width / 2)) / self.pixel_size,
                ((self.cy + self.height / 2) - y) / self.pixel_size)

    def to_world(self, column, row):
        return (self.cx - self.width / 2 + column * self.pixel_size,
                self.cy + self.height / 2 - row * self.pixel_size)

    def define_camera(self, stage: Usd.Stage, path: str, z: float) -> UsdGeom.Camera:
        camera = UsdGeom.Camera.Define(stage, path)
        camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
        # Apertures are in tenths of a scene unit (also for orthographic cameras).
        camera.CreateHorizontalApertureAttr(self.width * 10)
        camera.CreateVerticalApertureAttr(self.height * 10)
        camera.CreateClippingRangeAttr(Gf.Vec2f(0.01 * z, 10 * z))
        camera.AddTranslateOp().Set(Gf.Vec3d(self.cx, self.cy, z))
        return camera


def _filter_offsets(n: int = 5):
    """Sub-pixel offsets (px) and weights of the truncated Gaussian pixel filter."""
    offsets = (np.arange(n) + 0.5) / n * 2 * FILTER_RADIUS - FILTER_RADIUS
    w1 = np.exp(-offsets**2 / (2 * FILTER_SIGMA**2)) - math.exp(
        -(FILTER_RADIUS**2) / (2 * FILTER_SIGMA**2)
    )
    ox, oy = np.meshgrid(offsets, offsets)
    weights = np.outer(w1, w1)
    return ox.ravel(), oy.ravel(), (weights / weights.sum()).ravel()


@dataclass
class Reference:
    albedo: np.ndarray  # (H, W, 3) filtered expected diffuse albedo
    surface: np.ndarray  # (H, W) index into surfaces of the surface at the pixel centre, −1 none
    uniform: np.ndarray  # (H, W) True where everything within ±margin px is one surface and
    # colour, none of it clamped off the image
    surfaces: list[Surface]
    hits: _Hits | None = None  # every supersample, for reshade()
    clamped_any: np.ndarray | None = None  # (H, W) some samples of the pixel clamped off the image
    clamped_all: np.ndarray | None = None  # (H, W) all of them


def _hit(surfaces, x, y, view: OrthoView | None = None):
    """Index of the front-most surface and its st at world (x, y) arrays; with ``view``, x and
    y are (rows, columns, …) grids of that view, and each triangle only visits the pixels of
    its bounding box (plus the filter radius)."""
    best_z = np.full(x.shape, -np.inf)
    index = np.full(x.shape, -1, np.int64)
    st = np.zeros(x.shape + (2,))
    for i, surface in enumerate(surfaces):
        for t, tri in enumerate(surface.triangles):
            (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = tri
            det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
            if abs(det) < 1e-12:
                continue
            region = (Ellipsis,)
            if view is not None:
                c0, r0 = view.to_pixel(tri[:, 0].min(), tri[:, 1].max())
                c1, r1 = view.to_pixel(tri[:, 0].max(), tri[:, 1].min())
                pad = FILTER_RADIUS + 1
                rows = slice(max(int(r0 - pad), 0), max(int(r1 + pad) + 1, 0))
                cols = slice(max(int(c0 - pad), 0), max(int(c1 + pad) + 1, 0))
                region = (rows, cols)
            px, py = x[region], y[region]
            b0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
            b1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
            b2 = 1 - b0 - b1
            eps = -1e-9
            inside = (b0 >= eps) & (b1 >= eps) & (b2 >= eps)
            z = b0 * z0 + b1 * z1 + b2 * z2
            closer = inside & (z > best_z[region])
            best_z[region] = np.where(closer, z, best_z[region])
            index[region] = np.where(closer, i, index[region])
            if surface.st is not None:
                uv = (b0[..., None] * surface.st[t, 0] + b1[..., None] * surface.st[t, 1]
                      + b2[..., None] * surface.st[t, 2])
                st[region] = np.where(closer[..., None], uv, st[region])
    return index, st


def shade(surfaces, index, st, conv: Conventions = SPEC) -> np.ndarray:
    albedo = np.zeros(index.shape + (3,))
    for i, surface in enumerate(surfaces):
        mask = index == i
        if not mask.any():
            continue
        if surface.texture is not None:
            albedo[mask] = lookup(surface.texture, st[mask], conv)
        else:
            albedo[mask] = surface.constant
    return albedo


@dataclass
class _Hits:
    """Every supersample of a view: its surface and st, grouped by textured surface."""

    shape: tuple  # (H, W, n)
    weights: np.ndarray  # (n,) pixel filter weights
    base: np.ndarray  # (H·W·n, 3) albedo of untextured surfaces (0 where textured or none)
    groups: list  # [(surface index, flat sample indices, st)]

    def albedo_samples(self, surfaces, conv: Conventions) -> np.ndarray:
        out = self.base.copy()
        for i, flat, st in self.groups:
            out[flat] = lookup(surfaces[i].texture, st, conv)
        return out.reshape(self.shape + (3,))

    def albedo(self, surfaces, conv: Conventions) -> np.ndarray:
        return (self.albedo_samples(surfaces, conv) * self.weights[:, None]).sum(axis=2)

    def clamped(self, surfaces) -> np.ndarray:
        """(H, W, n): samples whose transformed st is off the image along a clamped axis. What
        such a sample shows depends on the mip level (clamp extends the edge texels of the
        level used), so it is no fixed expectation when an image has a thin frame."""
        out = np.zeros(self.base.shape[0], bool)
        for i, flat, st in self.groups:
            texture = surfaces[i].texture
            if texture.texels is None:
                continue
            st = transform_st(st, texture)
            for axis, mode in enumerate((texture.wrap_s, texture.wrap_t)):
                if mode not in ("repeat", "mirror"):
                    out[flat] |= (st[:, axis] < 0) | (st[:, axis] > 1)
        return out.reshape(self.shape)


def reference_render(
    stage: Usd.Stage, view: OrthoView, conv: Conventions = SPEC, margin: int = 2, samples: int = 4
) -> Reference:
    """The expected (filtered) albedo of every pixel and where it is uniform."""
    surfaces = collect_surfaces(stage)
    ox, oy, weights = _filter_offsets(samples)
    cols, rows = np.meshgrid(np.arange(view.pixels) + 0.5, np.arange(view.rows) + 0.5)
    sx = cols[..., None] + ox
    sy = rows[..., None] + oy
    wx, wy = view.to_world(sx, sy)
    index, st = _hit(surfaces, wx, wy, view)
    flat_index, flat_st = index.ravel(), st.reshape(-1, 2)
    base = np.zeros(flat_st.shape[:1] + (3,))
    groups = []
    for i, surface in enumerate(surfaces):
        flat = np.flatnonzero(flat_index == i)
        if surface.texture is not None:
            groups.append((i, flat, flat_st[flat]))
        else:
            base[flat] = surface.constant
    hits = _Hits(index.shape, weights, base, groups)
    albedo_samples = hits.albedo_samples(surfaces, conv)
    albedo = (albedo_samples * weights[:, None]).sum(axis=2)
    centre_index, _ = _hit(surfaces, *view.to_world(cols, rows), view)
    # Uniform: every supersample of the pixel and of its neighbours within `margin` px hits one
    # surface with one colour, so filtering (pixel filter, mip-maps) cannot change the value.
    lo = albedo_samples.min(axis=2)
    hi = albedo_samples.max(axis=2)
    same = (index == index[..., :1]).all(axis=2) & (index[..., 0] >= 0)
    clamped = hits.clamped(surfaces)
    uniform = same & ((hi - lo).max(axis=-1) < 1e-6) & ~clamped.any(axis=2)
    h, w = uniform.shape
    grown = uniform.copy()
    for dy in range(-margin, margin + 1):
        for dx in range(-margin, margin + 1):
            shifted = np.zeros_like(uniform)
            shifted_index = np.full_like(centre_index, -2)
            shifted_albedo = np.zeros_like(albedo)
            ys = slice(max(dy, 0), h + min(dy, 0))
            yd = slice(max(-dy, 0), h + min(-dy, 0))
            xs = slice(max(dx, 0), w + min(dx, 0))
            xd = slice(max(-dx, 0), w + min(-dx, 0))
            shifted[yd, xd] = uniform[ys, xs]
            shifted_index[yd, xd] = centre_index[ys, xs]
            shifted_albedo[yd, xd] = albedo[ys, xs]
            grown &= shifted & (shifted_index == centre_index)
            grown &= np.abs(shifted_albedo - albedo).max(axis=-1) < 1e-6
    return Reference(albedo=albedo, surface=centre_index, uniform=grown, surfaces=surfaces,
                     hits=hits, clamped_any=clamped.any(axis=2), clamped_all=clamped.all(axis=2))


def reshade(ref: Reference, conv: Conventions) -> np.ndarray:
    """The filtered albedo image of ``ref``'s view under other conventions."""
    return ref.hits.albedo(ref.surfaces, conv)


def add_calibration_patches(
    stage: Usd.Stage, like_shader: UsdShade.Shader, boxes: dict[str, tuple], root="/TestCalibration"
) -> dict[str, str]:
    """Quads in the z = 0 plane facing +Z, one per ``boxes`` entry ``name: ((x0, y0, x1, y1),
    albedo)``, each with a UsdPreviewSurface copying ``like_shader``'s unconnected inputs but
    with the constant diffuseColor ``albedo``. Returns name → mesh path."""
    paths = {}
    for name, ((x0, y0, x1, y1), albedo) in boxes.items():
        material = UsdShade.Material.Define(stage, f"{root}/Looks/{name}")
        shader = UsdShade.Shader.Define(stage, f"{root}/Looks/{name}/Surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        for shader_input in like_shader.GetInputs():
            if shader_input.HasConnectedSource() or not shader_input.GetAttr().HasAuthoredValue():
                continue
            shader.CreateInput(shader_input.GetBaseName(), shader_input.GetTypeName()).Set(
                shader_input.Get()
            )
        shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*albedo))
        material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        mesh = UsdGeom.Mesh.Define(stage, f"{root}/{name}")
        mesh.CreatePointsAttr([Gf.Vec3f(x0, y0, 0), Gf.Vec3f(x1, y0, 0), Gf.Vec3f(x1, y1, 0),
                               Gf.Vec3f(x0, y1, 0)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
        paths[name] = str(mesh.GetPath())
    return paths


def calibrate(color: np.ndarray, ref: Reference, white: str, black: str):
    """Per-channel (gain, offset) with rendered ≈ offset + gain · albedo, measured on the
    uniform pixels of a white (albedo 1) and a black (albedo 0) calibration patch."""
    paths = [s.path for s in ref.surfaces]
    means = {}
    for name in (white, black):
        mask = ref.uniform & (ref.surface == paths.index(name))
        if mask.sum() < 20:
            raise AssertionError(f"calibration patch {name} covers only {mask.sum()} pixels")
        means[name] = color[mask][:, :3].astype(np.float64).mean(axis=0)
    return means[white] - means[black], means[black]


def box_mean(color: np.ndarray, radius: int = 1) -> np.ndarray:
    """Mean over the (2r+1)² pixels around each pixel (edges: what exists)."""
    c = color[..., :3].astype(np.float64)
    h, w = c.shape[:2]
    total = np.zeros_like(c)
    count = np.zeros((h, w, 1))
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            ys = slice(max(dy, 0), h + min(dy, 0))
            yd = slice(max(-dy, 0), h + min(-dy, 0))
            xs = slice(max(dx, 0), w + min(dx, 0))
            xd = slice(max(-dx, 0), w + min(-dx, 0))
            total[yd, xd] += c[ys, xs]
            count[yd, xd] += 1
    return total / count


def texel_to_st(texture: Texture, column: float, row: float) -> np.ndarray:
    """The untransformed st (the primvar's value) that the spec maps to the continuous texel
    position (column, row) (row 0 at the top of the image): the inverse of UsdTransform2d."""
    h, w = texture.texels.shape[:2]
    st = np.array([column / w, 1.0 - row / h])
    if texture.transform is not None:
        scale, degrees, translation = texture.transform
        angle = -math.radians(degrees)
        c, s = math.cos(angle), math.sin(angle)
        v = st - translation
        st = np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]]) / scale
    return st


def world_at_st(surface: Surface, st: np.ndarray) -> np.ndarray:
    """World-space point of ``surface`` whose (untransformed) st is ``st``."""
    for tri, uv in zip(surface.triangles, surface.st):
        m = np.array([[uv[0, 0] - uv[2, 0], uv[1, 0] - uv[2, 0]],
                      [uv[0, 1] - uv[2, 1], uv[1, 1] - uv[2, 1]]])
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        b0, b1 = np.linalg.solve(m, st - uv[2])
        if min(b0, b1, 1 - b0 - b1) >= -1e-6:
            return b0 * tri[0] + b1 * tri[1] + (1 - b0 - b1) * tri[2]
    raise ValueError(f"{surface.path}: st {tuple(st)} is not on the mesh")


def surface_named(surfaces: list[Surface], path: str) -> Surface:
    for surface in surfaces:
        if surface.path == path:
            return surface
    raise KeyError(path)
