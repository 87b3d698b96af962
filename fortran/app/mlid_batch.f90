!> mlid-batch DECK... [--json FILE]: run every case of the decks, one deck
!> after another, without Python, as the original batch program did.  A
!> failing case prints one line naming deck, case and problem; the others
!> still run; so do the other decks when one cannot be read; the exit code
!> is 1 if any case failed or any deck could not be read.  Records and the
!> JSON file are written whole or not at all: to a temporary name in the
!> same folder, renamed when complete.
program mlid_batch
  use, intrinsic :: iso_c_binding, only: c_int, c_intptr_t, c_long, c_size_t, c_char
  use mlid_kinds, only: MLID_OK
  use mlid_case, only: case_t, case_uses
  use mlid_deck, only: deck_read
  use mlid_run, only: case_run_t, run_case
  use mlid_files, only: temporary_for, write_whole, same_file
  use mlid_report, only: json_list
  use mlid_text, only: itoa
  use mlid_wait_policy, only: brief_spin
  use mlid_interrupt, only: interrupt_arm, interrupt_requested
  use mlid_progress, only: progress_t
  use mlid_batch_progress, only: terminal_progress
  implicit none
  character(len=4096) :: deck, arg, json_path
  type(case_t), allocatable :: cases(:)
  integer :: status, nfail, k, nargs, ndeck, nunread, ncases, d
  character(len=256) :: msg
  character(len=:), allocatable :: objects, json_tmp
  logical, allocatable :: is_deck(:)
  !> A write of the report failed (stdout closed or full): said at the end,
  !> and the run fails, as mlid run's does (the Fortran runtime says nothing
  !> of a failed write to its preconnected unit, so the report goes out
  !> through write(2))
  logical :: stdout_lost = .false.

  call brief_spin()
  call ignore_file_size_signal()
  call interrupt_arm(.true.)
  nargs = command_argument_count()
  allocate (is_deck(nargs), source=.false.)
  json_path = ''
  k = 1
  do while (k <= nargs)
    call get_command_argument(k, arg)
    if (arg == '--json') then
      if (k == nargs) then
        write (0, '(a)') 'mlid-batch: --json needs a file name'
        stop 2, quiet=.true.
      end if
      call get_command_argument(k + 1, json_path)
      k = k + 1
    else if (arg(1:7) == '--json=') then       ! as Python's argparse takes it
      json_path = arg(8:)
    else if (arg == '-h' .or. arg == '--help') then
      write (*, '(a)') 'usage: mlid-batch DECK... [--json FILE]', &
        '  runs every case of the namelist decks, one deck after another (jobs: estimate, '// &
        'validate, simulate, design, monte_carlo), and prints the report'
      stop
    else if (arg(1:1) == '-') then
      write (0, '(a)') 'mlid-batch: unknown option '//trim(arg)
      stop 2, quiet=.true.
    else
      is_deck(k) = .true.
    end if
    k = k + 1
  end do
  ndeck = count(is_deck)
  if (ndeck == 0) then
    write (0, '(a)') 'usage: mlid-batch DECK... [--json FILE]'
    stop 2, quiet=.true.
  end if
  ! the JSON destination is tried before any case runs, and may not be a deck
  if (len_trim(json_path) > 0) then
    do d = 1, nargs
      call get_command_argument(d, deck)
      if (is_deck(d) .and. same_file(json_path, deck)) then
        write (0, '(a)') 'mlid-batch: cannot write --json '//trim(json_path)// &
          ' (a deck this run reads)'
        stop 1, quiet=.true.
      end if
    end do
    call temporary_for(trim(json_path), json_tmp, status, msg, '--json')
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      stop 1, quiet=.true.
    end if
    call json_not_an_input()
  end if

  nfail = 0
  nunread = 0
  ncases = 0
  objects = ''
  do d = 1, nargs
    if (.not. is_deck(d)) cycle
    call get_command_argument(d, deck)
    call deck_read(trim(deck), cases, status, msg)
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      if (ndeck == 1) stop 1, quiet=.true.
      nunread = nunread + 1
      cycle
    end if
    do k = 1, size(cases)
      call stop_if_interrupted()
      call run_one(k, cases(k))
    end do
    ncases = ncases + size(cases)
  end do
  call stop_if_interrupted()      ! a Ctrl-C during the last case's report: no JSON, as before it
  if (nfail > 0) write (0, '(i0,a,i0,a)') nfail, ' of ', ncases, ' cases failed'
  if (nunread > 0) write (0, '(i0,a,i0,a)') nunread, ' of ', ndeck, ' decks could not be read'
  if (len_trim(json_path) > 0) then
    call write_whole(trim(json_path), json_tmp, json_list(objects, ncases), status, msg)
    if (status /= MLID_OK) then
      write (0, '(a)') 'mlid-batch: '//trim(msg)
      stop 1, quiet=.true.
    end if
  end if
  if (stdout_lost) then
    write (0, '(a)') 'mlid-batch: the report could not be written to stdout (closed or full)'
    stop 1, quiet=.true.
  end if
  if (nfail > 0 .or. nunread > 0) stop 1, quiet=.true.

contains

  !> Ctrl-C (armed over the default at the start: mlid_interrupt.c) ends
  !> the case it came in, then the run: one line, no JSON written (its
  !> temporary was never made), exit code 130 as a shell gives for SIGINT;
  !> what earlier cases wrote stays, whole.  A second Ctrl-C ends it at once.
  subroutine stop_if_interrupted()
    if (.not. interrupt_requested()) return
    write (0, '(a)') 'mlid-batch: interrupted'
    stop 130, quiet=.true.
  end subroutine stop_if_interrupted

  !> text to stdout, whole; a failure (closed, full) is kept in stdout_lost.
  subroutine say(text)
    character(len=*), intent(in) :: text
    interface
      function c_write(fd, buf, n) bind(c, name='write') result(done)
        import :: c_int, c_long, c_size_t, c_char
        integer(c_int), value :: fd
        character(kind=c_char), intent(in) :: buf(*)
        integer(c_size_t), value :: n
        integer(c_long) :: done
      end function c_write
    end interface
    integer(c_long) :: done
    integer :: at
    at = 1
    do while (at <= len(text) .and. .not. stdout_lost)
      done = c_write(1_c_int, text(at:), int(len(text) - at + 1, c_size_t))
      stdout_lost = done <= 0
      if (done > 0) at = at + int(done)
    end do
  end subroutine say

  !> A file over the size limit (ulimit -f) is then a failed write, which the
  !> writers report in one line and clean up after, as Python's front end
  !> does, not a signal that kills the run (the runtime's handler prints a
  !> backtrace).  Linux's numbers: SIGXFSZ 25, SIG_IGN 1.
  subroutine ignore_file_size_signal()
    interface
      function c_signal(signum, handler) bind(c, name='signal') result(previous)
        import :: c_int, c_intptr_t
        integer(c_int), value :: signum
        integer(c_intptr_t), value :: handler
        integer(c_intptr_t) :: previous
      end function c_signal
    end interface
    integer(c_intptr_t) :: previous
    previous = c_signal(25_c_int, 1_c_intptr_t)
  end subroutine ignore_file_size_signal

  !> The JSON file may be no file a case reads or writes (case_uses): the
  !> decks are read once for that before any case runs (an unreadable one
  !> is reported when its turn comes).
  subroutine json_not_an_input()
    type(case_t), allocatable :: all(:)
    integer :: j, i
    do j = 1, nargs
      if (.not. is_deck(j)) cycle
      call get_command_argument(j, deck)
      call deck_read(trim(deck), all, status, msg)
      if (status /= MLID_OK) cycle
      do i = 1, size(all)
        if (case_uses(all(i), trim(json_path))) then
          write (0, '(a,i0,a)') 'mlid-batch: cannot write --json '//trim(json_path)// &
            ' (a file this run reads or writes: '//trim(deck)//' case ', i, ')'
          stop 1, quiet=.true.
        end if
      end do
    end do
  end subroutine json_not_an_input

  !> Run case k (mlid_run's run_case): print its heading and report, its
  !> notes on stderr, add its JSON object, count a failure.  Its long work
  !> shows a progress line when stderr is a terminal (mlid_batch_progress).
  subroutine run_one(k, c)
    integer, intent(in) :: k
    type(case_t), intent(inout) :: c
    type(case_run_t) :: r
    type(progress_t), target :: progress
    integer :: j

    call say(achar(10)//' case '//itoa(k)//': '//trim(c%title)//achar(10))
    if (terminal_progress(progress)) then      ! its long work's line on the terminal
      call run_case(c, r, progress=progress)
    else
      call run_case(c, r)
    end if
    call stop_if_interrupted()
    call say(r%report)
    do j = 1, size(r%notes)
      write (0, '(a,i0,a,i0,a)') 'mlid-batch: '//trim(deck)//' case ', k, ' (line ', c%line, &
        ') '''//trim(c%title)//''': '//r%notes(j)%s
    end do
    if (len(objects) > 0) objects = objects//','//achar(10)
    objects = objects//r%json
    if (r%status /= MLID_OK) nfail = nfail + 1
  end subroutine run_one

end program mlid_batch
