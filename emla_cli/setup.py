from setuptools import find_packages, setup

PACKAGE = 'emla_cli'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='emla developers',
    maintainer_email='dev@emla.invalid',
    description='The emla command line: identify, discrepancy, simulate, scenario, launch, play, echo, run.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'emla = emla_cli.cli:main',
        ],
    },
)
