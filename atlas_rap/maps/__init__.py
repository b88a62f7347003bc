"""Maps: map files (ROS map_server) now; occupancy grids and their abstractions next."""
