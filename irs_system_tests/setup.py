"""Install irs_system_tests as an ament_python package (all settings in setup.cfg)."""
from setuptools import setup

setup()
