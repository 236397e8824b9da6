# Source this file (". ./env.sh") in bash to use the workspace: it activates the venv,
# sources the colcon install, and keeps DDS on this machine.
_com_ws="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")" && pwd)"
# shellcheck disable=SC1091
. "$_com_ws/.venv/bin/activate"
if [ -f "$_com_ws/install/setup.bash" ]; then
    # shellcheck disable=SC1091
    . "$_com_ws/install/setup.bash"
    # the packages' executables (replay, sim_node, ...) by name, as `ros2 run` finds them
    for _com_bin in "$_com_ws"/install/*/lib/*/; do
        case ":$PATH:" in *":${_com_bin%/}:"*) ;; *) PATH="${_com_bin%/}:$PATH" ;; esac
    done
    export PATH
    unset _com_bin
fi
# DDS discovery stays on the loopback interface; a per-shell domain keeps parallel runs
# apart. Both may be overridden before sourcing.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( $$ % 100 + 1 ))}"
# One BLAS thread unless set: the fits' least squares are small, and on the cores the
# simulator and the other nodes keep busy a second thread waiting for one makes a motion's
# fit some four times slower (the estimator's answer past the sequencer's
# estimate_timeout).
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
unset _com_ws
