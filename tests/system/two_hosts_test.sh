#!/usr/bin/env bash
# Two machines of a vehicle as network namespaces joined by a veth pair: a procman deputy on each, the
# processes split as in procman/vehicle.pmd (sensor head, tracker and filter on "sensors"; e3d on
# "processing"), LCM over UDP multicast with ttl=1 across the link. Checks that filter states and stereo
# pairs reach the processing host and disparity maps come back; then drops 5 % of the packets on the link
# (tc netem, or nftables where the kernel has no netem) and checks that every process keeps running and that
# the losses are counted.
set -euo pipefail
BIN=$1; SRC=$2; W=${3:-$(mktemp -d)}
export PATH="$BIN:$PATH"
mkdir -p "$W"; rm -f "$W"/monitor_*.txt
A=ips_sensors_$$; B=ips_processing_$$
cleanup() {
  for ns in $A $B; do
    for p in $(ip netns pids $ns 2>/dev/null); do kill -TERM $p 2>/dev/null || true; done
  done
  sleep 1
  ip netns del $A 2>/dev/null || true; ip netns del $B 2>/dev/null || true
}
trap cleanup EXIT

sim --duration "${IPS_TWO_HOSTS_S:-10}" --out "$W/walk.lcmlog" --seed 3 --log-level warn

ip netns add $A; ip netns add $B
ip link add vs_$$ type veth peer name vp_$$
ip link set vs_$$ netns $A; ip link set vp_$$ netns $B
# Jumbo frames, as on a camera network: a 2.8 MB pair is 44 LCM fragments of 64 KiB instead of 2000 packets,
# so that under 5 % loss some pairs still arrive complete.
ip -n $A addr add 10.77.0.1/24 dev vs_$$; ip -n $B addr add 10.77.0.2/24 dev vp_$$
for ns_dev in "$A vs_$$" "$B vp_$$"; do
  set -- $ns_dev
  ip -n $1 link set lo up
  ip -n $1 link set $2 mtu 65535 up
  ip -n $1 route add 224.0.0.0/4 dev $2
done

export LCM_DEFAULT_URL="udpm://239.255.76.67:7741?ttl=1"
export IPS_RUN_DIR=$W IPS_CONFIG=$SRC/config IPS_TEST_DIR=$SRC/tests/system
ip netns exec $A procman-deputy --id sensors > "$W/deputy_sensors.log" 2>&1 &
ip netns exec $B procman-deputy --id processing > "$W/deputy_processing.log" 2>&1 &

# One run of the system; the monitors' reports are kept under the phase's name.
phase() {
  ip netns exec $A procman-sheriff --config "$SRC/tests/system/two_hosts.pmd" --id test-sheriff --timeout 240 \
    --script run > "$W/sheriff_$1.log" 2>&1 || { echo "FAIL: sheriff ($1)"; cat "$W/sheriff_$1.log"; exit 1; }
  ip netns exec $A procman-sheriff --status --timeout 3 > "$W/status_$1.log" 2>&1 || true
  mv "$W/monitor_processing.txt" "$W/monitor_processing_$1.txt"
  mv "$W/monitor_sensors.txt" "$W/monitor_sensors_$1.txt"
}
count() { sed -n "s/^channel=$2 received=\([0-9]*\).*/\1/p" "$W/$1"; }
field() { sed -n "s/^channel=$2 .*$3=\([0-9]*\).*/\1/p" "$W/$1"; }

phase clean
cat "$W/monitor_processing_clean.txt" "$W/monitor_sensors_clean.txt"
pairs=$(count monitor_processing_clean.txt STEREO)
states=$(count monitor_processing_clean.txt FILTER_STATE)
disp=$(count monitor_sensors_clean.txt DISPARITY)
[ "${states:-0}" -gt 100 ] || { echo "FAIL: filter states did not reach the processing host ($states)"; exit 1; }
[ "${pairs:-0}" -gt 40 ] || { echo "FAIL: stereo pairs did not reach the processing host ($pairs)"; exit 1; }
[ "$(field monitor_processing_clean.txt STEREO gaps)" = 0 ] || { echo "FAIL: pairs lost on a clean link"; exit 1; }
[ "${disp:-0}" -gt 0 ] || { echo "FAIL: no disparity map came back to the sensors host"; exit 1; }
echo "clean link: $pairs pairs and $states filter states reached 'processing', $disp disparity maps reached 'sensors'"

# 5 % packet loss on both ends of the link.
if ip netns exec $A tc qdisc add dev vs_$$ root netem loss 5% 2>/dev/null; then
  ip netns exec $B tc qdisc add dev vp_$$ root netem loss 5%
  echo "loss: tc netem 5 %"
else
  for ns in $A $B; do
    ip netns exec $ns nft add table inet lossy
    ip netns exec $ns nft add chain inet lossy in '{ type filter hook input priority 0; }'
    ip netns exec $ns nft add rule inet lossy in iifname != lo numgen random mod 100 \< 5 drop
  done
  echo "loss: this kernel has no netem; nftables drops 5 % of the packets entering each host"
fi
phase lossy
cat "$W/monitor_processing_lossy.txt" "$W/monitor_sensors_lossy.txt"
lossy_pairs=$(count monitor_processing_lossy.txt STEREO)
lossy_states=$(count monitor_processing_lossy.txt FILTER_STATE)
gaps=$(field monitor_processing_lossy.txt STEREO gaps)
[ "${lossy_states:-0}" -gt 50 ] || { echo "FAIL: the filter stopped reaching the processing host"; exit 1; }
[ "${lossy_states}" -lt "${states}" ] || { echo "FAIL: 5 % loss lost no filter state?"; exit 1; }
[ "${gaps:-0}" -gt 0 ] || { echo "FAIL: lost pairs not counted as sequence gaps"; exit 1; }
# e3d on the processing host counted the pairs it never got in its health message (seen by the monitor there).
grep -qE "e3d\.stereo_seq_gap=[1-9]" "$W/monitor_processing_lossy.txt" || { echo "FAIL: e3d did not count lost pairs"; exit 1; }
# Every process ran to the end: none left with an error status.
if grep -q "Stopped(Error)" "$W/status_lossy.log"; then echo "FAIL: a process died under loss"; cat "$W/status_lossy.log"; exit 1; fi
echo "PASS: under 5 % loss $lossy_pairs of the pairs and $lossy_states filter states arrived; $gaps pairs counted lost"
