"""Package-level names loaded on first use (PEP 562), so that importing a package for one node or command
does not load the numerics of all its modules."""
import importlib
import sys


def lazy_exports(package, exports):
    """(__getattr__, __dir__) for `package` that serve `exports` {name: module relative to the package}."""
    def getattr_(name):
        if name in exports:
            return getattr(importlib.import_module(f'{package}.{exports[name]}'), name)
        raise AttributeError(f'module {package!r} has no attribute {name!r}')

    def dir_():
        return sorted({*vars(sys.modules[package]), *exports})
    return getattr_, dir_
