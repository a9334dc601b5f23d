#!/usr/bin/env bash
# Installs rockwatch as systemd services (docs/deployment.md): the binary, the units, the
# configuration layout /etc/rockwatch and the system user `rockwatch`. Run as root from a
# checkout after `cargo build --release`. Idempotent; it never overwrites a file already in
# /etc/rockwatch (an operator's configuration), and enables nothing unless --enable is given.
#
# Usage: deploy/install.sh [--binary PATH] [--enable]
#   --binary PATH   the rockwatch binary (default: target/release/rockwatch of this checkout)
#   --enable        also `systemctl enable --now rockwatch-node` (acquire: enable it once
#                   /etc/rockwatch/acquire.toml names your server, streams and StationXML)
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
binary=$repo/target/release/rockwatch
enable=0
while [ $# -gt 0 ]; do
  case "$1" in
    --binary) binary=${2:?--binary needs a path}; shift 2 ;;
    --enable) enable=1; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "install.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
[ "$(id -u)" = 0 ] || { echo "install.sh: run as root (it writes /usr/local/bin, /etc)" >&2; exit 1; }
[ -x "$binary" ] || { echo "install.sh: $binary not found: run cargo build --release first" >&2; exit 1; }

say() { echo "install: $*"; }

install -m 0755 "$binary" /usr/local/bin/rockwatch
say "/usr/local/bin/rockwatch ($(/usr/local/bin/rockwatch --version))"

if ! id rockwatch >/dev/null 2>&1; then
  useradd --system --home-dir /var/lib/rockwatch --no-create-home --shell /usr/sbin/nologin rockwatch
  say "system user rockwatch"
fi

# /etc/rockwatch: the deployment's files, the example catalogue and the iceoryx2 config.
install -d -m 0755 /etc/rockwatch /etc/rockwatch/stationxml
place() { # SOURCE NAME: install unless present
  if [ -e "/etc/rockwatch/$2" ]; then
    say "/etc/rockwatch/$2 kept (already there)"
  else
    install -m 0644 "$1" "/etc/rockwatch/$2"
    say "/etc/rockwatch/$2"
  fi
}
for f in node.toml acquire.toml params.yaml environment; do
  place "$repo/deploy/etc/rockwatch/$f" "$f"
done
place "$repo/config/catalogue.toml" catalogue.toml
place "$repo/config/iceoryx2.toml" iceoryx2.toml

install -m 0644 "$repo/deploy/systemd/rockwatch-node.service" \
  "$repo/deploy/systemd/rockwatch-node@.service" \
  "$repo/deploy/systemd/rockwatch-acquire.service" /etc/systemd/system/
say "/etc/systemd/system/rockwatch-{node,node@,acquire}.service"
if command -v systemctl >/dev/null && [ -d /run/systemd/system ]; then
  systemctl daemon-reload
  if [ "$enable" = 1 ]; then
    systemctl enable --now rockwatch-node
    say "rockwatch-node enabled and started"
  fi
else
  say "systemd is not running here: units installed, nothing started"
fi
say "next: edit /etc/rockwatch/{catalogue.toml,acquire.toml}, then systemctl enable --now rockwatch-node rockwatch-acquire"
