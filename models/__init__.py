"""The MJCF models written for pik_mj (installed as the package data ``pik_mj.mjcf``;
found by name with :func:`pik_mj.models.model_path`)."""
