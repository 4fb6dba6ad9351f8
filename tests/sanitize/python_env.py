"""Sets up ``BUILD/venv``: a Python environment whose ``penumbra`` is the source package with the
sanitizer build's ``_core`` module (``make sanitize``).

The project's ``.venv`` holds an editable install whose import hook always serves the regular
build's ``_core``. This environment sees ``.venv``'s packages (usd-core, numpy, pytest) through
a path entry, without running that hook, and finds ``BUILD/site/penumbra`` first: links to the
package's files and to the sanitized module. ``penumbra-record``, ``penumbra-diff`` and
``dask`` sit beside its interpreter, as the tests expect.

    python tests/sanitize/python_env.py build/sanitize
"""

from __future__ import annotations

import sys
import sysconfig
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = {
    "penumbra-record": "penumbra.cli",
    "penumbra-diff": "penumbra.diff",
    "dask": "dask.__main__",  # the farm tests start schedulers and workers with it
}


def main(build: Path) -> None:
    build = build.resolve()
    modules = sorted((build / "python").glob("_core*.so"))
    if not modules:
        sys.exit(f"{build}/python holds no _core module: build it first")
    package = build / "site" / "penumbra"
    package.mkdir(parents=True, exist_ok=True)
    for old in package.iterdir():
        old.unlink()
    for source in sorted((ROOT / "python" / "penumbra").iterdir()):
        if source.name != "__pycache__" and not source.name.startswith("_core"):
            (package / source.name).symlink_to(source)
    (package / modules[0].name).symlink_to(modules[0])

    environment = build / "venv"
    venv.EnvBuilder(clear=True, symlinks=True, with_pip=False).create(environment)
    python = environment / "bin" / "python"
    own_site = Path(
        sysconfig.get_path("purelib", vars={"base": str(environment), "platbase": str(environment)})
    )
    project_site = Path(sysconfig.get_path("purelib"))  # .venv's, as this script runs in it
    (own_site / "penumbra_sanitize.pth").write_text(f"{build / 'site'}\n{project_site}\n")
    for name, module in SCRIPTS.items():
        script = environment / "bin" / name
        script.write_text(
            f"#!{python}\nimport sys\nfrom {module} import main\nsys.exit(main())\n"
        )
        script.chmod(0o755)


if __name__ == "__main__":
    main(Path(sys.argv[1]))
