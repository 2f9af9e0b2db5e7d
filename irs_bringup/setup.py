"""Install irs_bringup as an ament_python package (nodes land in lib/irs_bringup/ for ros2 run)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_bringup'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/experiments', glob('config/experiments/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='IRS team',
    maintainer_email='irs@example.org',
    description='Experiments on the IRS: graph bringup, MCAP recording, replay, plots.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'experiment = irs_bringup.run.experiment_cli:main',
            'bag = irs_bringup.bag.bag_cli:main',
            'recorder = irs_bringup.bag.recorder_node:main',
            'driver = irs_bringup.driver.driver_node:main',
            'container = irs_bringup.run.container:main',
        ],
        # Node classes the container composes in one process (rclpy's analogue of
        # rclcpp_components): <executable name> = <module>:<Node subclass>.
        'irs_components': [
            'driver = irs_bringup.driver.driver_node:DriverNode',
            'recorder = irs_bringup.bag.recorder_node:ComposableRecorder',
        ],
    },
)
