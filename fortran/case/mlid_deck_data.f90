!> The reader of a deck's &data group (mlid_deck): the records (one file
!> per manoeuvre), the channels taken of them by number or name, their
!> names, units and derived channels, each file's time window, the files
!> a validate case holds out, and the initial states per file.
submodule (mlid_deck) mlid_deck_data
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_text, only: text_lines, utf8_head
  use mlid_case, only: MAXSEG
  use mlid_channels, only: channels_spec, channels_join
  implicit none

contains

  !> &data: the records (one file per manoeuvre), the channels taken of
  !> them (by column number or name), the columns' names and units, derived
  !> channels, the units channels are shown in and the time window of each
  !> file.  Its lists are allocated (some 190 KB: not on a thread's stack).
  module procedure read_data_group
    character(len=PATHLEN), allocatable :: file(:), join(:)
    character(len=CHANLEN) :: time_col
    character(len=CHANLEN), allocatable :: input_cols(:), output_cols(:), columns(:), units(:), &
                                           show(:), join_columns(:)
    character(len=EXPRLEN), allocatable :: derived(:)
    real(wp) :: t_start(MAXSEG), t_end(MAXSEG), dt
    integer :: skip_rows, ios, status, holdout(MAXSEG), i, nh
    real(wp), allocatable :: ts(:), te(:)
    character(len=msg_len) :: iomsg, msg
    character(len=:), allocatable :: gtext
    namelist /data/ file, time_col, input_cols, output_cols, skip_rows, columns, units, &
      derived, show, t_start, t_end, holdout, dt, join, join_columns

    allocate (file(MAXSEG), join(MAXSEG), input_cols(MAXCOL), output_cols(MAXCOL), &
              columns(MAXCOL), units(MAXCOL), show(MAXCOL), join_columns(MAXCOL), &
              derived(MAXDER), stat=ios)
    if (ios /= 0) then
      call fail(c, 'group &data: out of memory for its lists')
      return
    end if
    file = ''
    join = ''
    join_columns = ''
    time_col = '1'
    input_cols = ''
    output_cols = ''
    columns = ''
    units = ''
    derived = ''
    show = ''
    t_start = -huge(1.0_wp)       ! a null keeps it: the file from its start
    t_end = huge(1.0_wp)          ! ... to its end
    skip_rows = 0
    holdout = 0
    dt = 0.0_wp
    call at_most(rd, c, 'data', [character(len=8) :: 'file', 'join', 't_start', 't_end', &
                                 'holdout'], MAXSEG, 'manoeuvres (data files)')
    if (c%status /= MLID_OK) return
    gtext = group_text(rd, 'data')
    ios = -1                          ! missing
    if (len(gtext) > 0) read (gtext, nml=data, iostat=ios, iomsg=iomsg)
    call group_status(rd, 'data', ios, iomsg, .true., c)
    if (c%status /= MLID_OK) return
    c%data_files = pack(file, len_trim(file) > 0)
    c%file_no = [(i, i=1, size(c%data_files))]
    call take_list(rd, c, 'data', 't_start', t_start, ts, .true., size(c%data_files))
    call take_list(rd, c, 'data', 't_end', t_end, te, .true., size(c%data_files))
    call list_length(rd, c, 'data', 'holdout', size(holdout), .false., nh)
    if (c%status /= MLID_OK) return
    call data_windows(c, ts, te)
    call data_holdout(c, holdout(1:nh))
    call check_data_group(c, [time_col, input_cols, output_cols, columns, units, show, &
                              join_columns], derived)
    if (c%status /= MLID_OK) return
    call channels_spec(time_col, as_text(input_cols), as_text(output_cols), as_text(columns), &
                       as_text(units), as_text(derived), as_text(show), skip_rows, c%chan, &
                       status, msg)
    if (status == MLID_OK) call channels_join(c%chan, text_lines(as_text(join)), &
                                              text_lines(as_text(join_columns)), &
                                              text_lines(as_text(c%data_files)), status, msg)
    if (status /= MLID_OK) call fail(c, 'group &data: '//trim(msg))
    if (is_given(rd, 'data', 'dt') .and. .not. (dt > 0.0_wp .and. ieee_is_finite(dt))) &
      call fail(c, 'group &data: dt must be > 0 (a uniform time step replacing the '// &
                'record''s time), or left out')
    if (c%status /= MLID_OK) return
    c%chan%dt = dt                                 ! 0: the record's own time
    if (c%job == 'stepwise') then        ! no &model: the channels are the variables and outputs
      c%nu = size(c%chan%inputs)
      c%ny = size(c%chan%outputs)
      if (c%ny == 0) call fail(c, 'group &data: a stepwise case needs output_cols (the '// &
                               'measured coefficients whose model structure it finds)')
    else if (size(c%chan%inputs) /= c%nu .or. size(c%chan%outputs) /= c%ny) then
      write (msg, '(a,i0,a,i0,a,i0,a,i0,a)') 'group &data: ', size(c%chan%inputs), &
        ' input_cols and ', size(c%chan%outputs), ' output_cols given, the model has ', c%nu, &
        ' inputs and ', c%ny, ' outputs'
      call fail(c, msg)
    end if
  end procedure read_data_group

  !> Each file's window: t_start and t_end in the order of file (those
  !> the deck gave); a file without one takes all of it.
  subroutine data_windows(c, t_start, t_end)
    type(case_t), intent(inout) :: c
    real(wp), intent(in) :: t_start(:), t_end(:)
    integer :: n
    n = size(c%data_files)
    c%win_start = spread(-huge(1.0_wp), 1, n)
    c%win_end = spread(huge(1.0_wp), 1, n)
    if (size(t_start) > n .or. size(t_end) > n) then
      call fail(c, 'group &data: more t_start or t_end than files ('//itoa(n)//')')
    else if (all(size(t_start) /= [0, n]) .or. all(size(t_end) /= [0, n])) then
      call fail(c, 'group &data: t_start and t_end take one value per file (in the order '// &
                'of file) or none; given '//itoa(size(t_start))//' and '// &
                itoa(size(t_end))//' for '//itoa(n)//' files')
    else
      if (size(t_start) == n) c%win_start = t_start
      if (size(t_end) == n) c%win_end = t_end
      if (any(c%win_end <= c%win_start)) &
        call fail(c, 'group &data: t_end must be after t_start (file '// &
                  itoa(findloc(c%win_end <= c%win_start, .true., 1))//')')
    end if
  end subroutine data_windows

  !> The files a validate case predicts: at least one, not all, each once.
  subroutine data_holdout(c, holdout)
    type(case_t), intent(inout) :: c
    integer, intent(in) :: holdout(:)
    integer :: n, k
    n = size(c%data_files)
    c%holdout = holdout
    if (c%status /= MLID_OK) return
    if (c%job /= 'validate') then
      if (size(c%holdout) > 0) call fail(c, 'group &data: holdout is for job ''validate''')
      return
    end if
    if (size(c%holdout) == 0 .or. size(c%holdout) >= n) then
      call fail(c, 'group &data: a validate case needs holdout, the numbers of the files to '// &
                'predict (at least one of the '//itoa(n)//' files, not all)')
    else if (any(c%holdout < 1 .or. c%holdout > n)) then
      call fail(c, 'group &data: holdout '//itoa(c%holdout(findloc(c%holdout < 1 .or. &
                c%holdout > n, .true., 1)))//' is no file number (1 to '//itoa(n)//')')
    else
      do k = 2, size(c%holdout)
        if (any(c%holdout(:k - 1) == c%holdout(k))) &
          call fail(c, 'group &data: holdout lists file '//itoa(c%holdout(k))//' twice')
      end do
    end if
  end subroutine data_holdout

  !> What &data must hold.  An entry that fills its whole length was cut.
  !> initial_states: nx values for each data file (each manoeuvre).
  module procedure check_initial_states
    if (.not. allocated(c%initial_states)) return
    if (size(c%initial_states) == 0) return
    if (c%job == 'validate') then
      call fail(c, 'group &model: initial_states is not available with job = ''validate''')
    else if (size(c%initial_states) /= c%nx*size(c%data_files)) then
      call fail(c, 'group &model: initial_states has '//itoa(size(c%initial_states))// &
                ' values; nx = '//itoa(c%nx)//' for each of the '//itoa(size(c%data_files))// &
                ' data files needs '//itoa(c%nx*size(c%data_files)))
    end if
  end procedure check_initial_states

  subroutine check_data_group(c, entries, derived)
    type(case_t), intent(inout) :: c
    character(len=*), intent(in) :: entries(:), derived(:)
    integer :: k
    if (c%status /= MLID_OK) return
    k = findloc(len_trim(entries) == len(entries), .true., 1)
    if (size(c%data_files) == 0) then
      call fail(c, 'group &data: file is missing')
    else if (k > 0) then
      call fail(c, 'group &data: "'//utf8_head(entries(k), 20)//'..." is longer than '// &
                itoa(len(entries))//' bytes')
    else if (any(len_trim(derived) == len(derived))) then
      call fail(c, 'group &data: a derived channel is longer than '//itoa(len(derived))// &
                ' bytes')
    end if
  end subroutine check_data_group

  !> The non-blank entries of an array, one per line (channels_spec's form).
  function as_text(texts) result(text)
    character(len=*), intent(in) :: texts(:)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(texts)
      if (len_trim(texts(k)) > 0) text = text//trim(texts(k))//achar(10)
    end do
  end function as_text

end submodule mlid_deck_data
