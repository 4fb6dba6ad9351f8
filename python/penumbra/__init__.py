"""Penumbra: a distributed ray tracer for USD stages.

```python
import penumbra
from pxr import Usd
stage = Usd.Stage.Open("scene.usda")
renderer = penumbra.Renderer(stage)
image = renderer.render(camera="/cam", time=1.0, width=640, samples=64, aovs=("color", "depth"))
image.write("out.exr")
```
"""

from . import _interrupts

with _interrupts.deferred():  # USD's module loader would swallow a Ctrl-C (_interrupts.py)
    from . import _core
    from ._core import write_vdb
    from .checkpoints import Checkpoint
    from .errors import PenumbraWarning, SceneError
    from .image import Image
    from .renderer import Renderer, render

__version__: str = _core.version()

__all__ = [
    "Checkpoint",
    "Image",
    "PenumbraWarning",
    "Renderer",
    "SceneError",
    "__version__",
    "render",
    "write_vdb",
]
