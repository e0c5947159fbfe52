"""Running experiments: the closed loop, the per-step record, run directories, single runs with their push-free
twins, ablation grids and the benchmark. The only package that wires controllers to the simulator."""
