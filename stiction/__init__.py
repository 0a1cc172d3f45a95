"""stiction: how sticky each control valve of a plant is.

One installed namespace: the product's packages (``stiction.sim``, ``stiction.ident``,
``stiction.detect``, ``stiction.bridge``, ``stiction.quantify``, ``stiction.agent``,
``stiction.trainer``, ``stiction.schemas``, ``stiction.bench``) are the top-level folders of the
source tree, mapped under this package by ``pyproject.toml``; the command line is
``stiction.cli`` and ``stiction.commands``.
"""

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    __version__ = version("stiction")
except PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0+unknown"

_TREE = Path(__file__).resolve().parent.parent
if (_TREE / "pyproject.toml").is_file() and (_TREE / "sim" / "__init__.py").is_file():
    # a source checkout (installed editable, or not at all): the packages are this folder's siblings
    __path__.append(str(_TREE))
