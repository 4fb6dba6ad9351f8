"""Penumbra's render options, defined once by the render delegate's table
(``_core.render_options()``, plugin/src/render_settings.cpp). Each front end spells an option
after its key: ``maxPathDepth`` is penumbra-record's ``--maxPathDepth``,
:meth:`penumbra.Renderer.render`'s ``max_path_depth`` and a UsdRenderSettings prim's
``penumbra:maxPathDepth``.
"""

from __future__ import annotations

import inspect
import numbers
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from . import _core

OptionValue = int | float | str
"""An option's value: an int, a float or a level's name (``complexity="high"``)."""

USD_ATTRIBUTE_PREFIX = "penumbra:"


def keyword_of(key: str) -> str:
    """The Python keyword of an option key: ``maxPathDepth`` → ``max_path_depth``."""
    return re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", key).lower()


@dataclass(frozen=True)
class RenderOption:
    """One row of the render delegate's option table: the core record's fields, read from it,
    and what Python derives from them."""

    core: _core.RenderOption

    @property
    def key(self) -> str:
        """The render delegate's key (``RenderDelegate.set_render_setting``), camelCase."""
        return self.core.key

    @property
    def type(self) -> str:
        """``"int"``, ``"float"`` or ``"level"`` (one of :attr:`levels`, by name)."""
        return self.core.type

    @property
    def default(self) -> OptionValue:
        return self.core.default

    @property
    def levels(self) -> tuple[str, ...]:
        return tuple(self.core.levels)

    @property
    def help(self) -> str:
        return self.core.help

    @property
    def default_meaning(self) -> str:
        """What the default does when its number does not say (``"off"``), or ``""``."""
        return self.core.default_meaning

    @property
    def metavar(self) -> str | None:
        return self.core.metavar or None

    @property
    def short_flag(self) -> str | None:
        return self.core.short_flag or None

    @property
    def usdrecord_flag(self) -> bool:
        return self.core.usdrecord_flag

    @property
    def changes_pixels(self) -> bool:
        """False for options that change only speed or memory (``threads``)."""
        return self.core.changes_pixels

    @property
    def keyword(self) -> str:
        return keyword_of(self.key)

    @property
    def flag(self) -> str:
        return f"--{self.key}"

    @property
    def usd_attribute(self) -> str:
        return USD_ATTRIBUTE_PREFIX + self.key

    @property
    def value_type(self) -> type:
        return {"int": int, "float": float, "level": str}[self.type]

    def problem(self, value: object) -> str | None:
        """Why ``value`` cannot be this option's (``"must be at least 1"``), or ``None``."""
        if self.type == "level":
            return None if value in self.levels else f"must be one of {', '.join(self.levels)}"
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return "must be a number"
        return self.core.problem(float(value)) or None

    def delegate_value(self, value: OptionValue) -> float:
        """``value`` (valid) as the render delegate's setting: a level by its index."""
        return float(self.levels.index(value) if self.type == "level" else value)


OPTIONS: tuple[RenderOption, ...] = tuple(
    RenderOption(option) for option in _core.render_options() if option.user_set
)
"""The options users set (the others the front ends derive from their own settings, as the
texture cache's size from the memory budget), in the order front ends list them."""
BY_KEYWORD: dict[str, RenderOption] = {option.keyword: option for option in OPTIONS}


def check(given: Mapping[str, object], function: str) -> None:
    """Raise as Python does (``TypeError``) for a name in ``given`` that is no option's
    keyword, ``function`` being the callee's name, and ``ValueError`` for an invalid value."""
    for name, value in given.items():
        if name not in BY_KEYWORD:
            raise TypeError(f"{function}() got an unexpected keyword argument {name!r}")
        option = BY_KEYWORD[name]
        problem = option.problem(value)
        if problem is not None:
            raise ValueError(f"{name} {problem}, not {value!r} (render setting {option.key})")


def resolve(
    given: Mapping[str, OptionValue], authored: Mapping[str, OptionValue] | None = None
) -> dict[str, OptionValue]:
    """Every option's value by keyword: as ``given`` (checked by :func:`check`), else as
    ``authored`` (a render settings prim's, checked as read), else its default."""
    authored = authored or {}
    return {
        option.keyword: given.get(option.keyword, authored.get(option.keyword, option.default))
        for option in OPTIONS
    }


def with_option_keywords(function: Callable) -> Callable:
    """``function``, whose ``**options`` take the render options, with a signature that lists
    them as keyword-only parameters with their defaults, so that ``help()``, ``inspect`` and
    editors show every option by name."""
    signature = inspect.signature(function)
    parameters = [p for p in signature.parameters.values() if p.kind is not p.VAR_KEYWORD]
    parameters += [
        inspect.Parameter(
            option.keyword, inspect.Parameter.KEYWORD_ONLY, default=option.default,
            annotation=option.value_type.__name__,
        )
        for option in OPTIONS
    ]
    function.__signature__ = signature.replace(parameters=parameters)
    return function
