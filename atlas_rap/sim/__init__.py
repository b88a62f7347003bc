"""The simulated robot: worlds, pymunk physics, the sonar ring, pictures of runs."""
