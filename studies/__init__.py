"""The paper's figures and our studies, one file each; installed as rodsim.studies."""
