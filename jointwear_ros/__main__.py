from jointwear_ros.cli import main

raise SystemExit(main())
