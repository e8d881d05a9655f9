from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'emla_sim'

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
    description='Actuator plant simulation and sensor sampling.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'plant = emla_sim.nodes.plant_node:main',
            'sensor = emla_sim.nodes.sensor_node:main',
        ],
    },
)
