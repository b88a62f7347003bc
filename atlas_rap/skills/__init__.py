"""Skills: the reactive tier. ``virtual`` holds scripted skills for runs without physics."""
