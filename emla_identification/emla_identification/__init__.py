"""emla_identification."""
