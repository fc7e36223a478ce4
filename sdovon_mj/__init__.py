"""sdovon-mj: MuJoCo-native SD-OVON dynamic scene and open-vocabulary ObjectNav generation."""

__version__ = "0.1.0"
