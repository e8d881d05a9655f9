from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'emla_core'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(),
    package_data={PACKAGE: ['nodes/fastdds.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='emla developers',
    maintainer_email='dev@emla.invalid',
    description='What every emla package uses: parameters and units, errors, recordings and data loading, '
                'topics and messages, bags, node plumbing and the recorder node.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'recorder = emla_core.nodes.recorder_node:main',
        ],
    },
)
