"""What the user touches: the scene's settings, the preferences, the sidebar panel, the Compute operator and the tool operators beside it."""
