"""Install irs_models as an ament_python package (no executables: a library of models)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_models'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='IRS team',
    maintainer_email='irs@example.org',
    description='ROS-free models shared by the IRS simulator, estimator and controller.',
    license='Apache-2.0',
)
