"""Writing a run's results into Blender and to files, as one transaction: nothing is written unless the run succeeded."""
