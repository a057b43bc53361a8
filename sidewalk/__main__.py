from sidewalk.cli import main

main()
