#!/bin/sh
# Certificates for a field network, with the openssl command line only (EC P-256).
#
#   cyborg-certs.sh DIR ca                    the network's CA: DIR/ca.crt, DIR/ca.key
#   cyborg-certs.sh DIR host NAME [SAN...]    a rig or router: serves TLS and dials out;
#                                             SAN like IP:192.168.1.20 or DNS:rig1.local
#   cyborg-certs.sh DIR user NAME             an operator's or viewer's client certificate
#
# NAME is the certificate's common name: the rig's name for a rig, the client name for a
# user (what the users file lists and the client passes as --name). Keys are written 0600;
# keep DIR/ca.key off the rig. Certificates last 825 days, the CA 10 years.
set -eu
usage() { sed -n '3,11p' "$0" >&2; exit 2; }
[ $# -ge 2 ] || usage
dir=$1 kind=$2
shift 2
mkdir -p "$dir"
cd "$dir"
umask 077
ec="-newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes"
leaf() { # name eku [san,...]
    [ -f ca.crt ] && [ -f ca.key ] || { echo "no CA in $dir: run '$0 $dir ca' first" >&2; exit 1; }
    # shellcheck disable=SC2086
    openssl req -x509 $ec -keyout "$1.key" -out "$1.crt" -days 825 -subj "/CN=$1" \
        -CA ca.crt -CAkey ca.key \
        -addext "basicConstraints=critical,CA:FALSE" \
        -addext "keyUsage=critical,digitalSignature" \
        -addext "extendedKeyUsage=$2" ${3:+-addext "subjectAltName=$3"} 2>/dev/null
    chmod 644 "$1.crt"
    openssl verify -CAfile ca.crt "$1.crt" >/dev/null
    echo "$dir/$1.crt $dir/$1.key"
}
case $kind in
ca)
    [ ! -e ca.key ] || { echo "$dir/ca.key exists; not overwriting it" >&2; exit 1; }
    # shellcheck disable=SC2086
    openssl req -x509 $ec -keyout ca.key -out ca.crt -days 3650 -subj "/CN=${1:-cyborg field CA}" \
        -addext "basicConstraints=critical,CA:TRUE" \
        -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
    chmod 644 ca.crt
    echo "$dir/ca.crt $dir/ca.key"
    ;;
host)
    [ $# -ge 1 ] || usage
    name=$1
    shift
    san="DNS:$name"
    for s in "$@"; do san="$san,$s"; done
    leaf "$name" serverAuth,clientAuth "$san"
    ;;
user)
    [ $# -eq 1 ] || usage
    case $1 in *[!A-Za-z0-9._-]*) echo "user name '$1': letters, digits, '.', '_', '-'" >&2; exit 2;; esac
    leaf "$1" clientAuth
    ;;
*) usage ;;
esac
