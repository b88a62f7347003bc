#!/bin/sh
# Certificates for the skill bus over mutual TLS (docs/how-to/skill-bus.md, "The skill bus across machines"):
# a certificate authority of your own, a certificate for the skill host (named after the
# host's address) and one for the sequencer. Run it in an empty folder:
#     sh make-certs.sh [HOST-NAME]        (default: localhost)
# Keep ca-key.pem offline; give the host host.pem, host-key.pem and ca.pem, and the
# sequencer sequencer.pem, sequencer-key.pem and ca.pem.
set -eu
host="${1:-localhost}"
days=365
ec="-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes"
openssl req -x509 $ec -days $days -keyout ca-key.pem -out ca.pem -subj "/CN=atlas-rap skill bus CA" 2>/dev/null
for who in host sequencer; do
    name="$who"
    [ "$who" = host ] && name="$host"
    openssl req $ec -keyout "$who-key.pem" -out "$who.csr" -subj "/CN=$name" 2>/dev/null
    printf 'subjectAltName=DNS:%s,IP:127.0.0.1\nextendedKeyUsage=serverAuth,clientAuth\n' "$name" > "$who.ext"
    openssl x509 -req -in "$who.csr" -CA ca.pem -CAkey ca-key.pem -CAcreateserial -days $days \
        -extfile "$who.ext" -out "$who.pem" 2>/dev/null
    rm "$who.csr" "$who.ext"
done
chmod 600 ./*-key.pem
echo "made ca.pem, host.pem, host-key.pem, sequencer.pem, sequencer-key.pem (CA key: ca-key.pem)"
