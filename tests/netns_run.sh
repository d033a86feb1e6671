#!/usr/bin/env bash
# Runs a command in a private network namespace with only loopback, and a multicast route on it, so that LCM's
# UDP multicast stays on this machine and tests running side by side never hear each other.
# Falls back to the host network (with a note) where namespaces are not allowed (not root).
set -euo pipefail
if [ "${IPS_IN_NETNS:-}" = "1" ]; then exec "$@"; fi
if unshare --net true 2>/dev/null; then
  exec unshare --net env IPS_IN_NETNS=1 bash -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec "$@"' netns "$@"
fi
echo "netns_run: cannot create a network namespace; using the host network" >&2
exec "$@"
