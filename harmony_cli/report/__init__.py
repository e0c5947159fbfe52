"""Results from run directories only: metrics on the per-step table, the run summary, Table-1 style and
experiment tables, console lines and figures. Nothing here touches the simulator."""
