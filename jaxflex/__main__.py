from jaxflex.cli import console

console()
