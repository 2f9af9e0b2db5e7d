"""Install irs_vehicle_sim as an ament_python package (all settings in setup.cfg)."""
from setuptools import setup

setup()
