"""ROS 2 plumbing shared by the nodes of every package (common) and the recorder node."""
