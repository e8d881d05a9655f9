"""emla_control."""
