#!/usr/bin/env bash
# The project's Java jar decodes a message published from C++, through lcm-spy's own type lookup
# (lcm.spy.LCMTypeDatabase over CLASSPATH), with the field values C++ put in.
set -euo pipefail
BIN=$1; JAR=$2; CLASSES=$3
U="udpm://239.255.76.67:7712?ttl=0"
out=$(mktemp)
CLASSPATH="$JAR:/usr/share/java/lcm.jar:$CLASSES" java -Djava.net.preferIPv4Stack=true SpyDecode "$U" IMU > "$out" 2>&1 &
j=$!
for i in $(seq 100); do grep -q ready "$out" && break; sleep 0.1; done
"$BIN/lcm_publish_sample" --lcm-url "$U" --count 100 --period-ms 100 &
p=$!
wait $j || true
kill $p 2>/dev/null || true; wait $p 2>/dev/null || true
cat "$out"
line=$(grep '^ips.imu_sample_t' "$out") || { echo "FAIL: not decoded"; exit 1; }
[[ "$line" == *"angular_rate=[0.125,-0.25,0.5]"* ]] || { echo "FAIL: angular_rate"; exit 1; }
[[ "$line" == *"specific_force=[0.0,0.0,9.80665]"* ]] || { echo "FAIL: specific_force"; exit 1; }
[[ "$line" == *"utime=1"* ]] || { echo "FAIL: utime"; exit 1; }
echo "PASS"
