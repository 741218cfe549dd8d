"""ament_python package jointwear_ros (builds with colcon, or pip install -e . in a venv)."""

from glob import glob

from setuptools import find_packages, setup

package_name = "jointwear_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "bench", "tools"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/config/params", glob("config/params/*.yaml")),
        ("share/" + package_name + "/launch", glob("launch/*.launch.py")),
        ("share/" + package_name + "/config/prometheus", glob("config/prometheus/*.yml")),
        ("share/" + package_name + "/config/grafana", glob("config/grafana/*.json")),
        ("share/" + package_name + "/config/foxglove", glob("config/foxglove/*")),
        ("share/" + package_name + "/config/dds", glob("config/dds/*.xml")),
    ],
    install_requires=["setuptools", "numpy", "scipy", "pyyaml", "matplotlib", "mcap", "rosbags", "threadpoolctl",
                      "sqlalchemy>=2.0", "psycopg[binary]>=3.1"],
    zip_safe=True,
    maintainer="jointwear maintainers",
    maintainer_email="maintainers@jointwear.dev",
    description="Robot-joint wear diagnosis from static friction (ROS 2 Jazzy node suite).",
    license="Apache-2.0",
    extras_require={"fleet": ["dask[distributed]"],  # jointwear fleet reprocess (Dask)
                    "serve": ["starlette", "uvicorn", "jinja2", "prometheus_client"]},  # jointwear serve
    entry_points={
        "console_scripts": [
            "jointwear = jointwear_ros.cli:main",
            "joint_sim = jointwear_ros.nodes.joint_sim:main",
            "test_cycle = jointwear_ros.nodes.test_cycle:main",
            "friction_observer = jointwear_ros.nodes.friction_observer:main",
            "wear_estimator = jointwear_ros.nodes.wear_estimator:main",
            "recorder = jointwear_ros.nodes.recorder:main",
            "wear_trend = jointwear_ros.nodes.wear_trend:main",
            "production_observer = jointwear_ros.nodes.production_observer:main",
            "cycle_on_demand = jointwear_ros.nodes.cycle_on_demand:main",
        ],
    },
)
