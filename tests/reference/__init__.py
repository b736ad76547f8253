"""Reference computations used only to validate the library (by tests and benchmarks): never
imported by the runtime packages."""
