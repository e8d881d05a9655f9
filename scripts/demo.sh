#!/usr/bin/env bash
# make demo: the default scenario end to end. The Table 1 actuator tracks the 40 ms square-wave stroke
# under adaptive control as a ROS 2 graph of processes (plant, sensor, identifier, controller, recorder)
# for a couple of simulated seconds; the bag is re-identified offline and the online estimates are plotted
# against the offline ones and the truth.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python
EMLA=.venv/bin/emla
DURATION=${DURATION:-2}
out=bags/demo-$(date +%Y%m%d-%H%M%S)
mkdir -p "$out"

"$EMLA" launch default --duration "$DURATION" --bag "$out/bag" --json "$out/launch.json"
# The offline identification (as `emla identify BAG --json F --plot F.png`), the estimates plot and the table in
# one Python process: each interpreter start with numpy, numba and matplotlib costs about a second.
"$PY" - "$out" <<'EOF'
import json, sys
from emla_cli.cli import main as emla
from emla_cli.estimate_plot import plot_estimates
out = sys.argv[1]
if emla(['identify', f'{out}/bag', '--json', f'{out}/identify.json', '--plot', f'{out}/identify.png']):
    sys.exit(1)
launch, offline = (json.load(open(f'{out}/{name}.json')) for name in ('launch', 'identify'))
plot_estimates(f'{out}/bag', offline, f'{out}/estimates.png')
print(f"\n{launch['duration']:g} s simulated in {launch['wall_time']:.1f} s wall "
      f"(real-time factor {launch['realtime_factor']}); {offline['samples']} samples recorded")
print(f"{'':14}{'true':>12}{'online':>12}{'offline':>12}")
for name, true in launch['true_parameters'].items():
    print(f"{name:14}{true:12.5g}{launch['final_parameters'][name]:12.5g}{offline['parameters'][name]:12.5g}")
EOF
cat <<EOF

bag (rosbag2, MCAP):            $out/bag
launch summary:                 $out/launch.json
offline identification:         $out/identify.json, $out/identify.png
online vs offline estimates:    $out/estimates.png
EOF
