"""fem_cloth: the Python side of the package (the generated messages live in fem_cloth.msg)."""
