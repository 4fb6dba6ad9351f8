"""Rendering UsdRender products: one EXR per product, each var a named channel set
(docs/aovs.md, "Render products")."""

from __future__ import annotations

import os
from collections.abc import Callable

from pxr import Usd

from . import cryptomatte
from .denoise import NOISY_COLOR
from .errors import SceneError, warn
from .image import COLOR_MODES, Image, check_output_directory, check_output_format
from .renderer import Renderer
from .usd.products import ProductPlan, RenderProduct, product_path


def render_products(
    renderer: Renderer,
    plan: ProductPlan,
    time_code: Usd.TimeCode,
    directory: str,
    *,
    camera: str | None = None,
    width: int | None = None,
    denoise: bool = False,
    color_mode: str = "openColorIO",
    on_render: Callable[[Image], None] | None = None,
    progress_for: Callable[[str], Callable[[int, int], None]] | None = None,
    **render_options,
) -> list[tuple[str, Image]]:
    """Render every product of ``plan`` at ``time_code`` and write it (atomically) to its
    ``productName`` with the frame substituted, relative to ``directory``. Products that share
    camera and settings are rendered once with all their vars. ``camera`` (a command line's)
    overrides the products'; ``width`` scales each product's resolution (None: as authored).
    ``denoise`` denoises the colour vars; a var whose sourceName is ``noisyColor`` keeps the
    colour as rendered. ``color_mode``: the display transform of products written as PNG, JPEG
    or TIFF, as :meth:`penumbra.Image.write`'s (``"openColorIO"``, ``"sRGB"`` or
    ``"disabled"``; another raises ``ValueError`` before anything renders); EXR products hold
    scene-linear values whatever it is. Returns each product's path and image; ``on_render``
    sees each render. ``progress_for`` makes each render's progress callback (``progress``)
    from the paths of the products it renders: each render counts its own samples.
    """
    if color_mode not in COLOR_MODES:
        raise ValueError(f"color_mode must be one of {COLOR_MODES}, not {color_mode!r}")
    frame = None if time_code.IsDefault() else time_code.GetValue()
    groups: dict[tuple, list[RenderProduct]] = {}
    for product in plan.products:
        groups.setdefault((product.settings, camera or product.settings.camera), []).append(product)
    written = []
    for (settings, group_camera), products in groups.items():
        aovs = ["color"] + sorted(
            {var.aov for product in products for var in product.vars} - {"color"}
        )
        if NOISY_COLOR in aovs and not denoise:
            aovs.remove(NOISY_COLOR)
            warn(f"{products[0].path}: a {NOISY_COLOR} var needs --denoise; skipped")
        options = dict(render_options)
        if progress_for is not None:
            options["progress"] = progress_for(", ".join(product.path for product in products))
        image = renderer.render(
            camera=group_camera,
            time=time_code,
            width=width,
            render_settings=settings,
            aovs=aovs,
            denoise=denoise,
            **options,
        )
        if on_render is not None:
            on_render(image)
        for product in products:
            path = os.path.join(directory, product_path(product.name, frame))
            _write_product(product, image, path, color_mode)
            written.append((path, image))
    return written


# AOVs whose values are ids that half floats cannot hold: Cryptomatte's (uint32 bits read as
# float32) and the integer ids (exact in half only up to 2048).
_EXACT_AOVS = frozenset((*cryptomatte.LAYERS, "primId", "instanceId", "elementId"))


def _write_product(product: RenderProduct, image: Image, path: str, color_mode: str) -> None:
    """The product's vars from ``image`` in one file: the first colour var as the unlayered R,
    G, B, A, every other var as channels named after its prim; a display format's colour
    through ``color_mode`` (:meth:`penumbra.Image.write`)."""
    layers, sources, half = {}, {}, []
    for var in product.vars:
        if var.aov not in image:
            continue  # noisyColor without denoising, reported once already
        layer = "color" if var.aov == "color" and "color" not in layers else var.layer
        if layer in layers:
            warn(f"{var.path}: another var of {product.path} is named {layer}; skipped")
            continue
        layers[layer] = image[var.aov]
        sources[layer] = var.aov
        if var.half and var.aov in _EXACT_AOVS:
            warn(f"{var.path}: {var.aov} needs 32-bit floats (half floats would change its "
                 "ids); written as float")
        elif var.half:
            half.append(layer)
    try:
        check_output_format(path)
        cryptomatte.check_output(path, sources.values())
        check_output_directory(path)
    except (ValueError, OSError) as error:
        raise SceneError(f"{product.path}: productName: {error}") from None
    metadata = {**cryptomatte.renamed(image.metadata, sources), "renderProduct": product.path}
    Image(layers, metadata, sources=sources).write(path, color_mode, half=half)
