# Sourced by scripts/container-check.sh and scripts/deb-check.sh (bash): picks the container
# engine and makes sure the base image is there. Expects ROOT (the repository), log and die.
# Sets ENGINE, BUILD_ARGS, RUN_ARGS and the function eng (the engine with its global flags).
#
# Engine: docker when its daemon answers, else podman; LOCI_CONTAINER_ENGINE=docker|podman
# forces one. podman runs with runc and cgroupfs and explicit rlimits (its default crun fails on
# hosts with hybrid cgroups and on rlimits). Every build and run uses the host network.
# Base image: debian:bookworm is pulled by docker; for podman, and when a pull fails,
# docker/debian-base.sh makes it with debootstrap from the host's Debian mirror.

ENGINE="${LOCI_CONTAINER_ENGINE:-}"
if [ -z "$ENGINE" ]; then
  if command -v docker >/dev/null && docker info >/dev/null 2>&1; then ENGINE=docker
  elif command -v podman >/dev/null; then ENGINE=podman
  else die "neither a running docker nor podman (apt-get install podman buildah runc debootstrap)"
  fi
fi
ENGINE_ARGS=()   # before the subcommand
BUILD_ARGS=(--network host)
RUN_ARGS=(--network host)
if [ "$ENGINE" = podman ]; then
  ENGINE_ARGS=(--runtime runc --cgroup-manager cgroupfs)
  BUILD_ARGS+=(--ulimit nofile=1024:1024 --ulimit nproc=1000:1000)
  RUN_ARGS+=(--ulimit nofile=1024:1024 --ulimit nproc=1000:1000)
fi
eng() { "$ENGINE" "${ENGINE_ARGS[@]}" "$@"; }
log "engine: $ENGINE ($("$ENGINE" --version))"

BASE=docker.io/library/debian:bookworm
if eng image inspect "$BASE" >/dev/null 2>&1; then
  log "base image $BASE present"
elif [ "$ENGINE" = docker ] && docker pull "$BASE" >/dev/null; then
  log "base image $BASE pulled"
else
  log "base image $BASE missing: docker/debian-base.sh (debootstrap)"
  "$ROOT/docker/debian-base.sh" "$ENGINE"
fi
