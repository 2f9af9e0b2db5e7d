# Source this file to use the IRS workspace in your shell:  source env/setup.bash
# (the venv with the ROS 2 Jazzy wheels, then the colcon install/ prefix with our packages;
# `source install/setup.bash` alone does the same, as on any ROS install).
_irs_here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$_irs_here/venv.bash"
if [ -f "$_irs_here/../install/setup.bash" ]; then
  source "$_irs_here/../install/setup.bash"
else
  echo "irs: install/ is missing; run 'make build' first" >&2
fi
unset _irs_here
