"""Install irs_hardware as an ament_python package (all settings in setup.cfg)."""
from setuptools import setup

setup()
