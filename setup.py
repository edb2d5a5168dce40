# The Python side of fem_cloth (src/fem_cloth): fem_cloth.batch, the batch runner behind
# scripts/fem_cloth_batch. Not for pip: catkin_python_setup() in CMakeLists.txt reads it.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=["fem_cloth", "fem_cloth.batch"], package_dir={"": "src"}))
