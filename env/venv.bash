# Source to put the IRS venv (a ROS 2 Jazzy install prefix made of ros-jazzy-* wheels) first.
source "$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/.venv/local_setup.sh"
