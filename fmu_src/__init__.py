"""The model: its C sources (lattice/), the FMI glue every model folder shares (common/, fmi2/, fmi3/, include/),
and what describes it in Python (variables.py, materials.py, published.py, the core's ctypes binding core.py).
builder/ compiles them into an FMU."""
