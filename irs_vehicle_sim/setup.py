"""Install irs_vehicle_sim as an ament_python package (nodes in lib/irs_vehicle_sim/, ros2 run)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_vehicle_sim'

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
    description='Simulated IRS rig: steering actuators, bicycle-model vehicle, treadmill belt and '
                'arm sensor.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'vehicle_sim = irs_vehicle_sim.vehicle_sim_node:main',
            'vehicle_tf = irs_vehicle_sim.tf_cli:main',
        ],
        # Node classes the container composes in one process (rclpy's analogue of
        # rclcpp_components): <executable name> = <module>:<Node subclass>.
        'irs_components': [
            'vehicle_sim = irs_vehicle_sim.vehicle_sim_node:VehicleSimNode',
        ],
    },
)
