"""Actuator models between the controller's command and the force on the suspension (one file each)."""
