"""A deliberately broken block module: importing it fails, as a bad plugin's would."""

raise ImportError("this plugin needs a library that is not installed (on purpose)")
