"""What crosses the process boundary: checkpoints and the replay store on disk, the run folder's
logs (metrics.csv, TensorBoard, provenance.json), benchmark result files, command-line parsing and
the machine's CPU. Imports nothing of the project outside this room."""
