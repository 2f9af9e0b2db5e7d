"""Install irs_common as an ament_python package."""
from setuptools import find_packages, setup

package_name = 'irs_common'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='IRS team',
    maintainer_email='irs@example.org',
    description='Node plumbing shared by the IRS nodes.',
    license='Apache-2.0',
)
