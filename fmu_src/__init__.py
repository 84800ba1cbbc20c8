"""The FMU's C sources: the model (lattice/) shared by every FMI version's glue."""

MODEL_SOURCES = ["lattice/lattice.c", "lattice/solver.c", "lattice/model.c"]
MODEL_HEADERS = ["lattice/lattice.h", "lattice/solver.h", "lattice/model.h", "lattice/compiler.h",
                 "lattice/dop853_coefficients.h"]
