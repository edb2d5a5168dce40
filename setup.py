# The Python side of fem_cloth (src/fem_cloth): fem_cloth.batch, the batch runner behind
# scripts/fem_cloth_batch, and fem_cloth.fit, behind scripts/fem_cloth_fit. Not for pip: catkin_python_setup() in CMakeLists.txt reads it.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["fem_cloth", "fem_cloth.batch", "fem_cloth.fit"], package_dir={"": "src"}))
