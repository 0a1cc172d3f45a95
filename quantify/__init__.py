"""The quantification method: windows (OP, PV) in, stiction reports out (ACF, INLPCA, the physical
reading, the ONNX networks, the verdict's evidence, the report's assembly); used by the agent, the trainer,
the benchmarks and the commands, and importing none of them."""
