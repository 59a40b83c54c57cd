#!/usr/bin/env bash
# Runs a sharded bake on Kubernetes: the three Jobs in order over the shared volume. Jobs
# have no dependencies of their own, so each step waits for the previous one to complete
# (a failed step stops here, and the later Jobs are never created).
#
#   deploy/k8s/run.sh            (kubectl's current context and namespace)
set -euo pipefail
here=$(dirname "$0")
kubectl apply -f "$here/pvc.yaml"
for step in tile-job shard-job merge-job; do
    kubectl apply -f "$here/$step.yaml"
    name=$(kubectl get -f "$here/$step.yaml" -o name)
    # Complete or Failed, whichever comes (`kubectl wait` waits for one condition only).
    while :; do
        state=$(kubectl get "$name" \
            -o jsonpath='{.status.conditions[?(@.status=="True")].type}')
        case " $state " in
            *" Complete "*) break ;;
            *" Failed "*)
                echo "error: $name failed; see kubectl logs -l job-name=${name#*/}" >&2
                exit 1
                ;;
        esac
        sleep 10
    done
done
echo "done: /bake/mesh.pvis on the patchvis-work volume"
