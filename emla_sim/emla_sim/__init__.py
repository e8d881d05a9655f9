"""emla_sim."""
