"""A package's flat public names, imported from their modules only when first used (PEP 562).

``atlas_rap.maps``, ``atlas_rap.sim`` and ``atlas_rap.cli`` list their public
names in ``__all__`` as ``atlas_rap.lang`` does, but their modules pull in
numpy, scipy, pymunk or click, and importing one module of a package runs
the package's ``__init__`` first: importing every module there would make
``atlas check`` and ``atlas_rap.views.map_render`` pay for all of them. So the
package's ``__getattr__`` imports a name's module when the name is asked for::

    _EXPORTS = {"grid": ("OccupancyGrid",), "topology": ("Topology", "build_topology")}
    __all__ = public_names(_EXPORTS)
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
"""

from __future__ import annotations

import importlib
from typing import Any, Callable

__all__ = ["lazy_exports", "public_names"]


def public_names(exports: dict[str, tuple[str, ...]]) -> list[str]:
    """The names of ``exports`` (module → names), sorted: a package's ``__all__``."""
    return sorted(name for names in exports.values() for name in names)


def lazy_exports(package: str, exports: dict[str, tuple[str, ...]]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package``, whose modules (``exports``: module name
    within the package → the public names it defines) are imported at a name's first use."""
    where = {name: f"{package}.{module}" for module, names in exports.items() for name in names}

    def __getattr__(name: str) -> Any:
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(where[name]), name)

    def __dir__() -> list[str]:
        return sorted(set(importlib.import_module(package).__dict__) | set(where))

    return __getattr__, __dir__
