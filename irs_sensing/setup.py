"""Install irs_sensing as an ament_python package (nodes land in lib/irs_sensing/ for ros2 run)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'irs_sensing'

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
    description='Arm pose estimation: potentiometer angles to the car pose, velocities and '
                'lateral displacement.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'arm_pose_estimator = irs_sensing.arm_pose_estimator_node:main',
        ],
        # Node classes the container composes in one process (rclpy's analogue of
        # rclcpp_components): <executable name> = <module>:<Node subclass>.
        'irs_components': [
            'arm_pose_estimator = irs_sensing.arm_pose_estimator_node:ArmPoseEstimatorNode',
        ],
    },
)
