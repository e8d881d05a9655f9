from setuptools import find_packages, setup

PACKAGE = 'emla_bench'

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
    description='The closed-loop bench: plant, sensor, identifier and controller in-process; named scenarios.',
    license='Apache-2.0',
)
