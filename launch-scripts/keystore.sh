#!/usr/bin/env bash
# Creates a DDS Security (SROS2) keystore for rockwatch with openssl only — no ROS 2 needed.
#
# Usage: launch-scripts/keystore.sh [--days N] [--domains MIN-MAX] [--namespace NS]... DIR
#   DIR        the keystore to create (must not exist, or be empty). Then run every rockwatch
#              process with
#                ROS_SECURITY_KEYSTORE=DIR ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce
#              (README, "DDS Security"). Each command picks its enclave (below);
#              ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/... chooses another one.
#   --days N   validity of the certificates (default 3650).
#   --domains  the DDS domain ids the governance and permissions cover (default 0-232).
#   --namespace NS  the ROS 2 namespace of the node (`[ros2] namespace`, e.g. /site_a for
#              rockwatch-node@site_a): the pbr topics and /pbr/reset are granted under it
#              (rt/site_a/pbr/alerts, …). Repeat it for several sites; default /.
#
# Layout (that of `ros2 security create_keystore` / `create_enclave`, so SROS2's tools and any
# ROS 2 middleware with security read it):
#   DIR/public/{identity_ca,permissions_ca}.cert.pem   the two CAs (separate keys)
#   DIR/private/{identity_ca,permissions_ca}.key.pem   their private keys (0600: keep DIR/private
#                                                      off the machines that run nodes)
#   DIR/enclaves/governance.{xml,p7s}                  the domain's rules, signed
#   DIR/enclaves/<enclave>/{cert.pem,key.pem,governance.p7s,permissions.{xml,p7s},
#                           identity_ca.cert.pem,permissions_ca.cert.pem}
#
# Enclaves and what they may do (DDS names: ROS 2 topic /a/b is rt/a/b; service /pbr/reset is
# rq/pbr/resetRequest + rr/pbr/resetReply; every enclave may use ROS 2's own ros_discovery_info,
# rt/clock (read),
# rt/rosout and rt/parameter_events):
#   /rockwatch/node      the node: reads /pbr/accel, a partitioned node's /pbr/accel/p<i>of<N>
#                        (docs/capacity.md) and any Imu topic (all three as rt/*), publishes
#                        /pbr/alerts, /pbr/state, /pbr/ims, /pbr/intake, /pbr/markers, /diagnostics,
#                        /tf_static (its 3-D view), serves /pbr/reset and its
#                        parameter services
#   /rockwatch/station   replay / acquire: publishes /pbr/accel and the partition topics
#                        /pbr/accel/p<i>of<N> of a scaled-out service (rt/pbr/accel/p*: the
#                        permissions' topic expressions are fnmatch patterns, `*` matching `/`
#                        too, in RustDDS (glob::Pattern) and Cyclone DDS alike) and acquire's
#                        status on /diagnostics, reads /pbr/intake
#   /rockwatch/operator  `rockwatch reset --node`: calls /pbr/reset
#   /rockwatch/reader    reads /pbr/alerts, /pbr/state, /pbr/ims, /pbr/markers, /tf_static
# The governance refuses unauthenticated participants, encrypts discovery, liveliness and data,
# signs every RTPS message, and checks read and write access on every topic.
set -euo pipefail

days=3650
domains="0-232"
namespaces=()
while [ $# -gt 1 ]; do
  case "$1" in
    --days) days="$2"; shift 2 ;;
    --domains) domains="$2"; shift 2 ;;
    --namespace)
      case "$2" in
        /|/[A-Za-z]*) ;;
        *) echo "keystore.sh: --namespace must be an absolute ROS 2 namespace (/ or /site_a), got '$2'" >&2; exit 2 ;;
      esac
      case "$2" in *[!A-Za-z0-9_/]*|*//*) echo "keystore.sh: --namespace '$2' is not a ROS 2 namespace" >&2; exit 2 ;; esac
      namespaces+=("$2"); shift 2 ;;
    *) echo "keystore.sh: unknown option $1 (usage: keystore.sh [--days N] [--domains MIN-MAX] [--namespace NS]... DIR)" >&2; exit 2 ;;
  esac
done
if [ $# -ne 1 ]; then
  echo "usage: keystore.sh [--days N] [--domains MIN-MAX] [--namespace NS]... DIR" >&2
  exit 2
fi
[ ${#namespaces[@]} -gt 0 ] || namespaces=(/)
ks="$1"
case "$days" in ''|*[!0-9]*) echo "keystore.sh: --days must be a positive integer, got '$days'" >&2; exit 2 ;; esac
dmin="${domains%-*}"; dmax="${domains#*-}"
case "$dmin$dmax" in ''|*[!0-9]*) echo "keystore.sh: --domains must be MIN-MAX, got '$domains'" >&2; exit 2 ;; esac
command -v openssl >/dev/null || { echo "keystore.sh: openssl not found (apt-get install openssl)" >&2; exit 1; }
if [ -e "$ks" ] && [ -n "$(ls -A "$ks" 2>/dev/null)" ]; then
  echo "keystore.sh: $ks exists and is not empty: refusing to overwrite a keystore" >&2
  exit 1
fi

umask 077
mkdir -p "$ks/public" "$ks/private" "$ks/enclaves"
ks="$(cd "$ks" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# prime256v1 ECDSA, as SROS2 and the DDS Security builtin plugins (ECDSA-SHA256) expect.
openssl ecparam -name prime256v1 -out "$tmp/ec.pem"

# The two certificate authorities (self-signed).
for ca in identity_ca permissions_ca; do
  openssl req -x509 -new -nodes -newkey "ec:$tmp/ec.pem" -sha256 -days "$days" \
    -keyout "$ks/private/$ca.key.pem" -out "$ks/public/$ca.cert.pem" \
    -subj "/CN=rockwatch $ca" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign,digitalSignature" \
    2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
done
chmod 0644 "$ks/public/"*.pem

sign() { # sign IN.xml OUT.p7s with the permissions CA (S/MIME, clear text, as SROS2)
  openssl smime -sign -text -in "$1" -out "$2" \
    -signer "$ks/public/permissions_ca.cert.pem" -inkey "$ks/private/permissions_ca.key.pem" \
    2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
}

# From a day back, so a host whose clock lags a little still accepts the grants.
not_before="$(date -u -d "-1 day" +%Y-%m-%dT%H:%M:%S)"
not_after="$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)"

cat > "$ks/enclaves/governance.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>$dmin</min><max>$dmax</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
sign "$ks/enclaves/governance.xml" "$ks/enclaves/governance.p7s"
chmod 0644 "$ks/enclaves/governance.xml" "$ks/enclaves/governance.p7s"

topics() { for t in "$@"; do printf '          <topic>%s</topic>\n' "$t"; done; }

# enclave NAME "PUBLISH TOPICS" "SUBSCRIBE TOPICS" (DDS topic names, globs allowed)
enclave() {
  local name="$1" pub="$2" sub="$3" dir="$ks/enclaves$1"
  # The topic lists hold DDS patterns (rt/*): never expanded as file names here.
  local -
  set -f
  mkdir -p "$dir"
  openssl req -new -nodes -newkey "ec:$tmp/ec.pem" -sha256 -keyout "$dir/key.pem" \
    -out "$tmp/req.pem" -subj "/CN=${name//\//\\/}" 2>"$tmp/err" || { cat "$tmp/err" >&2; exit 1; }
  openssl x509 -req -in "$tmp/req.pem" -sha256 -days "$days" \
    -CA "$ks/public/identity_ca.cert.pem" -CAkey "$ks/private/identity_ca.key.pem" \
    -set_serial "0x$(openssl rand -hex 16)" -out "$dir/cert.pem" 2>"$tmp/err" \
    || { cat "$tmp/err" >&2; exit 1; }
  # shellcheck disable=SC2086
  cat > "$dir/permissions.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name</subject_name>
      <validity><not_before>$not_before</not_before><not_after>$not_after</not_after></validity>
      <allow_rule>
        <domains><id_range><min>$dmin</min><max>$dmax</max></id_range></domains>
        <publish><topics>
$(topics ros_discovery_info rt/rosout rt/parameter_events $pub)
        </topics></publish>
        <subscribe><topics>
$(topics ros_discovery_info rt/clock $sub)
        </topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  sign "$dir/permissions.xml" "$dir/permissions.p7s"
  # The CA certificates and governance next to each identity (SROS2 uses symlinks too).
  local up
  up="$(printf '%s' "$name" | sed 's|/[^/]*|../|g')"
  ln -s "${up}governance.p7s" "$dir/governance.p7s"
  ln -s "${up}../public/identity_ca.cert.pem" "$dir/identity_ca.cert.pem"
  ln -s "${up}../public/permissions_ca.cert.pem" "$dir/permissions_ca.cert.pem"
  chmod 0644 "$dir/cert.pem" "$dir/permissions.xml" "$dir/permissions.p7s"
  chmod 0755 "$dir"
}

# The pbr names under every namespace: /site_a/pbr/alerts is rt/site_a/pbr/alerts.
under() { local f="$1" ns p; shift; for ns in "${namespaces[@]}"; do
  p="${ns%/}"; for t in "$@"; do printf '%s ' "${f}${p}/$t"; done; done; }
enclave /rockwatch/node \
  "$(under rt pbr/alerts pbr/state pbr/ims pbr/intake pbr/markers) $(under rr pbr/resetReply) rt/diagnostics rt/tf_static rr/*rockwatch/*" \
  "rt/* $(under rq pbr/resetRequest) rq/*rockwatch/*"
enclave /rockwatch/station "$(under rt pbr/accel 'pbr/accel/p*') rt/diagnostics" "$(under rt pbr/intake)"
enclave /rockwatch/operator "$(under rq pbr/resetRequest)" "$(under rr pbr/resetReply)"
enclave /rockwatch/reader "" "$(under rt pbr/alerts pbr/state pbr/ims pbr/markers) rt/tf_static"

chmod 0755 "$ks" "$ks/public" "$ks/enclaves" "$ks/enclaves/rockwatch"
chmod 0600 "$ks/private/"*.pem
chmod 0700 "$ks/private"
# Every signature checks against its CA before the keystore is handed out.
for f in "$ks"/enclaves/governance.p7s "$ks"/enclaves/rockwatch/*/permissions.p7s; do
  openssl smime -verify -in "$f" -CAfile "$ks/public/permissions_ca.cert.pem" -out /dev/null 2>"$tmp/err" \
    || { echo "keystore.sh: $f does not verify:" >&2; cat "$tmp/err" >&2; exit 1; }
done
for e in "$ks"/enclaves/rockwatch/*/; do
  openssl verify -CAfile "$ks/public/identity_ca.cert.pem" "$e/cert.pem" >/dev/null
done
echo "keystore $ks: enclaves /rockwatch/node /rockwatch/station /rockwatch/operator /rockwatch/reader"
