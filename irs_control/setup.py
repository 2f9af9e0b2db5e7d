"""Install irs_control as an ament_python package (nodes land in lib/irs_control/ for ros2 run)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_control'

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
    description='Lateral control of the scale car: MRC/RST pole placement and PI, reference '
                'generation.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'lateral_controller = irs_control.lateral_controller_node:main',
            'reference_generator = irs_control.reference_generator_node:main',
            'rst_design = irs_control.design_cli:main',
        ],
        # Node classes the container composes in one process (rclpy's analogue of
        # rclcpp_components): <executable name> = <module>:<Node subclass>.
        'irs_components': [
            'lateral_controller = irs_control.lateral_controller_node:LateralControllerNode',
            'reference_generator = irs_control.reference_generator_node:ReferenceGeneratorNode',
        ],
    },
)
