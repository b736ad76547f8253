"""Package discovery for the two import roots (everything else is in pyproject.toml).

``pasim_graph`` lives in ``pasim_graph/``; ``pasim_blocks`` in ``blocks/``. setuptools'
``packages.find`` cannot rename a folder, so the packages under each root are found here
(folders without ``__init__.py``, such as ``pasim_blocks.data``, count: they hold package
data).
"""

from setuptools import find_namespace_packages, setup

ROOTS = {"pasim_graph": "pasim_graph", "pasim_blocks": "blocks"}


def packages() -> list[str]:
    found = []
    for name, folder in ROOTS.items():
        found.append(name)
        for sub in find_namespace_packages(folder, exclude=["*__pycache__*", "*.egg-info"]):
            found.append(f"{name}.{sub}")
    return sorted(found)


setup(packages=packages())
