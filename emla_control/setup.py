from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'emla_control'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='emla developers',
    maintainer_email='dev@emla.invalid',
    description='Adaptive inverse-system control: the law, the stroke reference, the controller node.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'controller = emla_control.nodes.controller_node:main',
        ],
    },
)
