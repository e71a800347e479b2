"""The deployment files say what the code needs: a GPU worker group for the trainer with the CUDA image."""

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def test_the_raycluster_has_a_gpu_group_for_the_trainer_on_the_cuda_image():
    cluster = yaml.safe_load((ROOT / "deploy" / "raycluster.yaml").read_text())
    groups = {g["groupName"]: g for g in cluster["spec"]["workerGroupSpecs"]}
    gpu = groups["train-gpu"]
    container = gpu["template"]["spec"]["containers"][0]
    assert container["resources"]["limits"]["nvidia.com/gpu"] == "1"
    assert container["image"].endswith("-cuda") and gpu["minReplicas"] == 0
    assert all("nvidia.com/gpu" not in g["template"]["spec"]["containers"][0]["resources"]["limits"]
               for name, g in groups.items() if name != "train-gpu")
    dockerfile = (ROOT / "deploy" / "Dockerfile").read_text()
    assert 'ARG TORCH_INDEX=' in dockerfile and '--index-url "$TORCH_INDEX" torch==2.13.0' in dockerfile


# The fields of the KubeRay v1 types our manifests may use, as ray-project/kuberay documents them
# (docs/reference/api.md, generated from the same Go types as ray-operator/config/crd/bases/ray.io_rayclusters.yaml
# and ray.io_rayjobs.yaml). Types: a name of this table, "X[]" a list of X, "map" string to string (KubeRay refuses
# rayStartParams values that are not strings), "quantities" (resource amounts), "object" (not checked deeper).
KUBERAY_V1 = {
    "RayCluster": {"apiVersion": "string", "kind": "string", "metadata": "ObjectMeta", "spec": "RayClusterSpec"},
    "RayJob": {"apiVersion": "string", "kind": "string", "metadata": "ObjectMeta", "spec": "RayJobSpec"},
    "RayJobSpec": {"activeDeadlineSeconds": "integer", "backoffLimit": "integer", "rayClusterSpec": "RayClusterSpec",
                   "submitterPodTemplate": "PodTemplateSpec", "metadata": "map", "clusterSelector": "map",
                   "submitterConfig": "object", "managedBy": "string", "deletionStrategy": "object",
                   "entrypoint": "string", "runtimeEnvYAML": "string", "jobId": "string", "submissionMode": "string",
                   "entrypointResources": "string", "entrypointNumCpus": "number", "entrypointNumGpus": "number",
                   "ttlSecondsAfterFinished": "integer", "shutdownAfterJobFinishes": "boolean", "suspend": "boolean",
                   "schedule": "string"},
    "RayClusterSpec": {"suspend": "boolean", "managedBy": "string", "autoscalerOptions": "object",
                       "headServiceAnnotations": "map", "enableInTreeAutoscaling": "boolean",
                       "gcsFaultToleranceOptions": "object", "headGroupSpec": "HeadGroupSpec", "rayVersion": "string",
                       "workerGroupSpecs": "WorkerGroupSpec[]"},
    "HeadGroupSpec": {"template": "PodTemplateSpec", "headService": "object", "enableIngress": "boolean",
                      "rayStartParams": "map", "serviceType": "string"},
    "WorkerGroupSpec": {"suspend": "boolean", "groupName": "string", "replicas": "integer", "minReplicas": "integer",
                        "maxReplicas": "integer", "idleTimeoutSeconds": "integer", "rayStartParams": "map",
                        "template": "PodTemplateSpec", "scaleStrategy": "object", "numOfHosts": "integer"},
}
# The Kubernetes core v1 fields our pod templates and other manifests use (a subset: anything else is refused here,
# so that a misspelt field shows instead of being dropped by the API server).
CORE_V1 = {
    "Namespace": {"apiVersion": "string", "kind": "string", "metadata": "ObjectMeta"},
    "PersistentVolumeClaim": {"apiVersion": "string", "kind": "string", "metadata": "ObjectMeta", "spec": "PVCSpec"},
    "PVCSpec": {"accessModes": "string[]", "storageClassName": "string", "resources": "ResourceRequirements"},
    "Secret": {"apiVersion": "string", "kind": "string", "metadata": "ObjectMeta", "type": "string",
               "stringData": "map"},
    "ObjectMeta": {"name": "string", "namespace": "string", "labels": "map", "annotations": "map"},
    "PodTemplateSpec": {"metadata": "ObjectMeta", "spec": "PodSpec"},
    "PodSpec": {"containers": "Container[]", "volumes": "Volume[]", "securityContext": "PodSecurityContext",
                "tolerations": "Toleration[]", "restartPolicy": "string", "nodeSelector": "map",
                "serviceAccountName": "string"},
    "PodSecurityContext": {"fsGroup": "integer", "runAsUser": "integer", "runAsGroup": "integer",
                           "runAsNonRoot": "boolean"},
    "Container": {"name": "string", "image": "string", "imagePullPolicy": "string", "command": "string[]",
                  "args": "string[]", "env": "EnvVar[]", "resources": "ResourceRequirements",
                  "volumeMounts": "VolumeMount[]"},
    "EnvVar": {"name": "string", "value": "string", "valueFrom": "EnvVarSource"},
    "EnvVarSource": {"secretKeyRef": "KeySelector", "configMapKeyRef": "KeySelector"},
    "KeySelector": {"name": "string", "key": "string", "optional": "boolean"},
    "ResourceRequirements": {"requests": "quantities", "limits": "quantities"},
    "VolumeMount": {"name": "string", "mountPath": "string", "readOnly": "boolean", "subPath": "string"},
    "Volume": {"name": "string", "persistentVolumeClaim": "PVCVolumeSource"},
    "PVCVolumeSource": {"claimName": "string", "readOnly": "boolean"},
    "Toleration": {"key": "string", "operator": "string", "value": "string", "effect": "string",
                   "tolerationSeconds": "integer"},
}
TYPES = {**KUBERAY_V1, **CORE_V1}
SCALARS = {"string": str, "integer": int, "number": (int, float), "boolean": bool}


def field_problems(value, kind: str, path: str) -> list[str]:
    """Every field of ``value`` that type ``kind`` does not have, or whose value has the wrong type."""
    if kind.endswith("[]"):
        if not isinstance(value, list):
            return [f"{path}: expected a list"]
        return [p for k, item in enumerate(value) for p in field_problems(item, kind[:-2], f"{path}[{k}]")]
    if kind in SCALARS:
        wrong = not isinstance(value, SCALARS[kind]) or (kind != "boolean" and isinstance(value, bool))
        return [f"{path}: expected {kind}, got {value!r}"] if wrong else []
    if kind in ("map", "quantities"):
        allowed = str if kind == "map" else (str, int)
        return [f"{path}.{k}: expected a string, got {v!r}" for k, v in (value or {}).items()
                if not isinstance(v, allowed) or isinstance(v, bool)]
    if kind == "object":
        return [] if isinstance(value, dict) else [f"{path}: expected an object"]
    fields = TYPES[kind]
    return [problem for key, item in value.items()
            for problem in ([f"{path}.{key}: no such field in {kind}"] if key not in fields
                            else field_problems(item, fields[key], f"{path}.{key}"))]


def manifests() -> dict[str, dict]:
    return {path.name: yaml.safe_load(path.read_text()) for path in sorted((ROOT / "deploy").glob("*.yaml"))}


def test_every_manifest_uses_only_fields_of_its_kubernetes_or_kuberay_type():
    found = manifests()
    assert {"raycluster.yaml", "rayjob.yaml", "pvc.yaml", "secret.yaml", "namespace.yaml"} <= set(found)
    for name, manifest in found.items():
        assert field_problems(manifest, manifest["kind"], name) == [], name


def test_a_misspelt_or_mistyped_field_is_caught():
    cluster = manifests()["raycluster.yaml"]
    cluster["spec"]["workerGroupSpec"] = cluster["spec"].pop("workerGroupSpecs")
    cluster["spec"]["headGroupSpec"]["rayStartParams"]["num-cpus"] = 0
    problems = field_problems(cluster, "RayCluster", "raycluster.yaml")
    assert "raycluster.yaml.spec.workerGroupSpec: no such field in RayClusterSpec" in problems
    assert any("rayStartParams.num-cpus: expected a string" in p for p in problems)


def pod_specs(manifest: dict) -> list[dict]:
    spec = manifest["spec"]
    cluster = spec.get("rayClusterSpec", spec)
    pods = [cluster["headGroupSpec"]["template"]["spec"], *(g["template"]["spec"] for g in cluster["workerGroupSpecs"])]
    return pods + ([spec["submitterPodTemplate"]["spec"]] if "submitterPodTemplate" in spec else [])


def test_every_ray_pod_has_the_token_the_volume_and_a_writable_fs_group():
    found = manifests()
    secret, claim = found["secret.yaml"]["metadata"]["name"], found["pvc.yaml"]["metadata"]["name"]
    namespace = found["namespace.yaml"]["metadata"]["name"]
    assert found["pvc.yaml"]["spec"]["accessModes"] == ["ReadWriteMany"]
    for name in ("raycluster.yaml", "rayjob.yaml"):
        assert found[name]["metadata"]["namespace"] == namespace
        for pod in pod_specs(found[name]):
            env = {e["name"]: e for e in pod["containers"][0]["env"]}
            assert env["RAY_AUTH_MODE"]["value"] == "token", name
            assert env["RAY_AUTH_TOKEN"]["valueFrom"]["secretKeyRef"] == {"name": secret, "key": "token"}, name
            if pod.get("restartPolicy") != "Never":  # Ray nodes, not the submitter
                assert pod["securityContext"]["fsGroup"] == 1000, name
                assert pod["volumes"][0]["persistentVolumeClaim"]["claimName"] == claim, name
        head = pod_specs(found[name])[0]["containers"][0]["resources"]
        assert float(head["requests"]["cpu"]) >= 1, f"{name}: the head hosts the driver and the central actors"


def test_the_image_ray_the_manifests_ray_and_the_package_ray_are_one_version():
    import re

    dockerfile = (ROOT / "deploy" / "Dockerfile").read_text()
    image = re.search(r"ARG RAY_VERSION=([\d.]+)", dockerfile).group(1)
    assert '"ray[default]==${RAY_VERSION}"' in dockerfile and "useradd --create-home --uid 1000 ray" in dockerfile
    assert "chown -R ray:ray /opt/onepiece-dist" in dockerfile  # the work folder is the image user's
    found = manifests()
    versions = {found["raycluster.yaml"]["spec"]["rayVersion"],
                found["rayjob.yaml"]["spec"]["rayClusterSpec"]["rayVersion"]}
    assert versions == {image}
    pyproject = (ROOT / "pyproject.toml").read_text()
    pinned = re.search(r'"ray\[default\]==([\d.*]+)"', pyproject).group(1)
    assert image.startswith(pinned.rstrip("*").rstrip(".")), (image, pinned)
    import ray

    assert ray.__version__ == image  # the version the tests run against


def test_the_docker_context_leaves_out_local_state():
    ignored = (ROOT / ".dockerignore").read_text().split()
    assert {".git", ".venv", "**/*.zarr"} <= set(ignored)


def test_the_installed_packages_meet_the_declared_bounds_and_numpy_is_2():
    import tomllib
    from importlib.metadata import version

    from packaging.requirements import Requirement

    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    for requirement in map(Requirement, declared):
        if requirement.marker is None or requirement.marker.evaluate():
            assert requirement.specifier.contains(version(requirement.name), prereleases=True), str(requirement)
    numpy = next(Requirement(r) for r in declared if r.startswith("numpy"))
    assert not numpy.specifier.contains("1.26.4")  # np.bitwise_count (the voxel code) is numpy 2


def test_the_launcher_config_brings_up_workers_with_the_token_and_the_package():
    config = yaml.safe_load((ROOT / "cluster" / "cluster.yaml").read_text())
    head = " ".join(config["head_start_ray_commands"])
    assert "--autoscaling-config=~/ray_bootstrap_config.yaml" in head  # without it the head starts no workers
    assert "RAY_AUTH_MODE=token" in head and "--dashboard-host=127.0.0.1" in head
    starts = [c for c in config["worker_start_ray_commands"] if "ray start" in c]
    assert starts and all("RAY_AUTH_MODE=token" in c for c in starts)  # all() over none would pass
    assert config["file_mounts"]["~/.ray/auth_token"] and config["file_mounts"]["/opt/onepiece-dist"] == "."
    setup = " ".join(config["setup_commands"])
    assert "apt-get update" in setup and "chmod 600 ~/.ray/auth_token" in setup
    assert config["min_workers"] == len(config["provider"]["worker_ips"])
