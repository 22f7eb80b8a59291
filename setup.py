"""Package layout that pyproject.toml cannot express with package discovery: the
top-level ``scenarios/`` is installed as ``pik_mj.scenarios`` and ``models/`` as
``pik_mj.mjcf`` (MJCF files only), next to every ``pik_mj*`` package found."""

from setuptools import find_packages, setup

setup(
    packages=[*find_packages(include=["pik_mj", "pik_mj.*"]), "pik_mj.scenarios", "pik_mj.mjcf"],
    package_dir={"pik_mj.scenarios": "scenarios", "pik_mj.mjcf": "models"},
)
