"""`cameras.record3d`: an iPhone or iPad running the Record3D app, streaming RGB-D over USB."""
