"""Everything that generates and compiles an FMU from a model folder of fmu_src/: the C header and model
descriptions from the variable table, the documentation page, the compiler calls, the zip (build.py), and the
cross-check and reference-result files. It sits above the model and the scenes: fmu_src/ imports nothing here."""
