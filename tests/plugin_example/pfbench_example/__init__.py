"""An example pfbench plug-in package (see pfbench's README, "Adding a filter")."""
