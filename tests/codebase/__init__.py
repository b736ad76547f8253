"""The repository as a whole: lint, types, import layers, layout and packaging."""
