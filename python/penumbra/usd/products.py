"""UsdRender products and vars: what a render settings prim asks to be written (docs/aovs.md,
"Render products").

Each ``RenderProduct`` of the settings' ``products`` is one EXR at its ``productName``, holding
its ``orderedVars`` as named channel sets. A ``RenderVar`` maps onto a Penumbra AOV by its
``sourceType``: ``raw`` and ``intrinsic`` name the AOV (Hydra's names too), ``primvar`` names a
primvar, ``lpe`` the light path expressions that mean the beauty. Products may override the
settings' camera, resolution and other UsdRenderSettingsBase attributes. Whatever is authored
and not honoured is reported once with a warning naming the prim and the attribute.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

from pxr import Usd, UsdRender

from ..errors import SceneError, warn
from ..frames import frame_path
from .settings import CONFORM_POLICIES, RenderSettings, read_pixel_aspect_ratio

AOV_NAMES = (
    "color",
    "alpha",
    "depth",
    "Z",
    "normal",
    "Neye",
    "position",
    "albedo",
    "primId",
    "instanceId",
    "elementId",
    "sampleCount",
    "variance",
    "noisyColor",
    "CryptoObject",
    "CryptoMaterial",
    "CryptoAsset",
)
"""The AOVs a ``raw`` or ``intrinsic`` RenderVar may name (besides ``primvars:NAME``);
``noisyColor`` only with denoising."""
AOV_ALIASES = {
    "cameraDepth": "depth",
    "N": "normal",
    "P": "position",
    "Ci": "color",
    "crypto_object": "CryptoObject",
    "crypto_material": "CryptoMaterial",
    "crypto_asset": "CryptoAsset",
}
"""Other renderers' names for the same AOVs."""
BEAUTY_LPES = ("C.*", "C.*[<L.>O]", "C[DS]*[<L.>O]")
"""Light path expressions that mean all light reaching the camera: the color AOV."""
HALF_TYPES = ("half", "half2", "half3", "half4", "color3h", "color4h", "normal3h", "point3h")
FLOAT_TYPES = (
    "float", "float2", "float3", "float4", "color3f", "color4f", "normal3f", "point3f",
    "vector3f", "int", "uint", "int64",
)  # fmt: skip
"""dataTypes written as 32-bit floats (integer ids too: exact up to 2^24)."""

_BASE_ATTRIBUTES = {
    "camera",
    "resolution",
    "pixelAspectRatio",
    "aspectRatioConformPolicy",
    "dataWindowNDC",
    "instantaneousShutter",
    "disableMotionBlur",
    "disableDepthOfField",
}
SUPPORTED = {
    "settings": _BASE_ATTRIBUTES | {"products", "includedPurposes", "materialBindingPurposes"},
    "product": _BASE_ATTRIBUTES | {"productType", "productName", "orderedVars"},
    "var": {"dataType", "sourceName", "sourceType"},
}
DEFAULT_BINDING_PURPOSES = ("full", "")
"""The material binding purposes Penumbra resolves (full, then all-purpose bindings)."""


@dataclass(frozen=True)
class RenderVar:
    """One RenderVar as written: its channel set's name (the prim's name) and its AOV."""

    path: str
    layer: str
    aov: str
    half: bool


@dataclass(frozen=True)
class RenderProduct:
    path: str
    name: str
    """``productName``: the file, with frame placeholders ($F, $F4, or a run of #)."""
    settings: RenderSettings
    """The render settings with this product's overrides applied."""
    vars: tuple[RenderVar, ...]


@dataclass(frozen=True)
class ProductPlan:
    """The products of a render settings prim, and the settings-wide choices they share."""

    products: tuple[RenderProduct, ...]
    included_purposes: tuple[str, ...] | None
    """``includedPurposes`` when authored."""


def read_products(stage: Usd.Stage, settings: RenderSettings) -> ProductPlan:
    """The products of ``settings``'s prim (products with no usable var are skipped with a
    warning); raises :class:`SceneError` for a product without a ``productName``."""
    prim = stage.GetPrimAtPath(settings.path)
    schema = UsdRender.Settings(prim)
    _warn_unsupported(prim, "settings")
    purposes_attr = schema.GetIncludedPurposesAttr()
    purposes = (
        tuple(str(p) for p in purposes_attr.Get()) if purposes_attr.HasAuthoredValue() else None
    )
    binding_attr = schema.GetMaterialBindingPurposesAttr()
    if binding_attr.HasAuthoredValue():
        binding = tuple(str(p) for p in binding_attr.Get())
        if binding not in (DEFAULT_BINDING_PURPOSES, ("full",)):
            warn(
                f"{prim.GetPath()}: materialBindingPurposes {list(binding)} is not supported; "
                "materials bound for the full purpose, else for all purposes, are used"
            )
    if schema.GetInstantaneousShutterAttr().Get():
        settings = dataclasses.replace(settings, disable_motion_blur=True)
    products = []
    for target in schema.GetProductsRel().GetForwardedTargets():
        product = _read_product(stage, target, settings)
        if product is not None:
            products.append(product)
    return ProductPlan(tuple(products), purposes)


def _read_product(stage: Usd.Stage, path, settings: RenderSettings) -> RenderProduct | None:
    prim = stage.GetPrimAtPath(path)
    product = UsdRender.Product(prim)
    if not product:
        warn(f"{settings.path}: products target {path}, which is not a RenderProduct; skipped")
        return None
    _warn_unsupported(prim, "product")
    product_type = str(product.GetProductTypeAttr().Get())
    if product_type != "raster":
        warn(f"{path}: productType {product_type!r} is not supported; written as a raster image")
    name = str(product.GetProductNameAttr().Get() or "")
    if not name:
        raise SceneError(f"{path}: the render product has no productName")
    render_vars = []
    for var_path in product.GetOrderedVarsRel().GetForwardedTargets():
        render_var = _read_var(stage, var_path)
        if render_var is not None:
            render_vars.append(render_var)
    if not render_vars:
        warn(f"{path}: the render product has no var Penumbra can write; skipped")
        return None
    return RenderProduct(str(path), name, _overridden(product, settings), tuple(render_vars))


def _overridden(product: UsdRender.Product, settings: RenderSettings) -> RenderSettings:
    """``settings`` with the UsdRenderSettingsBase attributes the product authors."""
    changes: dict[str, object] = {}
    cameras = product.GetCameraRel().GetForwardedTargets()
    if cameras:
        changes["camera"] = str(cameras[0])
    resolution = product.GetResolutionAttr()
    if resolution.HasAuthoredValue():
        width, height = resolution.Get()
        if width < 1 or height < 1:
            raise SceneError(f"{product.GetPath()}: resolution must be positive, not {(width, height)}")
        changes["resolution"] = (int(width), int(height))
    aspect = product.GetPixelAspectRatioAttr()
    if aspect.HasAuthoredValue():
        changes["pixel_aspect_ratio"] = read_pixel_aspect_ratio(aspect)
    policy = product.GetAspectRatioConformPolicyAttr()
    if policy.HasAuthoredValue():
        if str(policy.Get()) not in CONFORM_POLICIES:
            raise SceneError(f"{product.GetPath()}: unknown aspectRatioConformPolicy {policy.Get()!r}")
        changes["aspect_ratio_conform_policy"] = str(policy.Get())
    window = product.GetDataWindowNDCAttr()
    if window.HasAuthoredValue():
        x_min, y_min, x_max, y_max = (float(v) for v in window.Get())
        if not (x_min < x_max and y_min < y_max):
            raise SceneError(f"{product.GetPath()}: dataWindowNDC is empty")
        changes["data_window_ndc"] = (x_min, y_min, x_max, y_max)
    for attribute, field in (
        (product.GetDisableMotionBlurAttr(), "disable_motion_blur"),
        (product.GetInstantaneousShutterAttr(), "disable_motion_blur"),
        (product.GetDisableDepthOfFieldAttr(), "disable_depth_of_field"),
    ):
        if attribute.HasAuthoredValue() and attribute.Get():
            changes[field] = True
    return dataclasses.replace(settings, **changes)


def _read_var(stage: Usd.Stage, path) -> RenderVar | None:
    prim = stage.GetPrimAtPath(path)
    render_var = UsdRender.Var(prim)
    if not render_var:
        warn(f"{path}: not a RenderVar; skipped")
        return None
    _warn_unsupported(prim, "var")
    source_type = str(render_var.GetSourceTypeAttr().Get())
    source_name = str(render_var.GetSourceNameAttr().Get() or "")
    aov = var_aov(source_type, source_name)
    if aov is None:
        warn(
            f"{path}: sourceName {source_name!r} ({source_type}) is not an AOV Penumbra "
            f"renders (known: {', '.join(AOV_NAMES)}, primvars:NAME, LPEs {', '.join(BEAUTY_LPES)}); "
            "skipped"
        )
        return None
    data_type = str(render_var.GetDataTypeAttr().Get())
    if data_type not in HALF_TYPES + FLOAT_TYPES:
        warn(f"{path}: dataType {data_type!r} is not supported; written as float")
    return RenderVar(str(path), prim.GetName(), aov, data_type in HALF_TYPES)


def var_aov(source_type: str, source_name: str) -> str | None:
    """The Penumbra AOV a RenderVar's source means, or ``None``."""
    if source_type == "primvar":
        name = source_name.removeprefix("primvars:")
        return f"primvars:{name}" if name else None
    if source_type == "lpe":
        return "color" if source_name in BEAUTY_LPES else None
    if source_type in ("raw", "intrinsic"):
        name = AOV_ALIASES.get(source_name, source_name)
        if name in AOV_NAMES or (name.startswith("primvars:") and len(name) > len("primvars:")):
            return name
    return None


def _warn_unsupported(prim: Usd.Prim, kind: str) -> None:
    """One warning per authored property of ``prim`` that Penumbra does not honour."""
    for prop in prim.GetAuthoredProperties():
        name = prop.GetName()
        if name not in SUPPORTED[kind]:
            warn(f"{prim.GetPath()}: {name} is not supported; ignored")


HOUDINI_FRAME = re.compile(r"\$F(\d*)")
"""A productName's ``$F`` or ``$F4`` frame placeholder."""


def product_path(name: str, frame: float | None) -> str:
    """``productName`` with its frame placeholders replaced: ``$F`` (``$F4``: zero-padded to
    4 digits; fractional frames as their shortest decimals) and usdrecord's ``#`` runs
    (:func:`penumbra.frames.frame_path`). ``frame`` None (the default time) leaves them."""
    if frame is None:
        return name

    def houdini(match: re.Match) -> str:
        width = int(match.group(1) or 1)
        return f"{int(frame):0{width}d}" if float(frame).is_integer() else f"{frame:0{width}g}"

    return frame_path(HOUDINI_FRAME.sub(houdini, name), frame)
