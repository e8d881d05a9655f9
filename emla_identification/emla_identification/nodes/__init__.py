"""ROS 2 adapters of the package."""
