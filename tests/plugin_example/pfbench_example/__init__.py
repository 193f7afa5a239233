"""An example pfbench plug-in package (see pfbench's docs, docs/how-to/plugins.md)."""
