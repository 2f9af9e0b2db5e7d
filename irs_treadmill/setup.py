"""Install irs_treadmill as an ament_python package (nodes in lib/irs_treadmill/ for ros2 run)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_treadmill'

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
    description='Treadmill belt speed regulation that keeps the car at its longitudinal set '
                'point.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'treadmill_regulator = irs_treadmill.treadmill_regulator_node:main',
        ],
        # Node classes the container composes in one process (rclpy's analogue of
        # rclcpp_components): <executable name> = <module>:<Node subclass>.
        'irs_components': [
            'treadmill_regulator = irs_treadmill.treadmill_regulator_node:TreadmillRegulatorNode',
        ],
    },
)
